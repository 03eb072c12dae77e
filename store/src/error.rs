//! What a load or a save of the configuration store can fail with: the flash's own error
//! kind, a region or flash geometry the store cannot use, a record too long, a record of
//! another format version, a write that did not read back.

use embedded_storage::nor_flash::NorFlashErrorKind;

/// Why a [`Store::load`](crate::Store::load) or [`Store::save`](crate::Store::save) failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StoreError {
    /// The flash driver failed (its error kind).
    Flash(NorFlashErrorKind),
    /// The region (base, page count) or the flash's sizes do not fit the store: fewer than
    /// two pages, a base not on a page boundary, a region past the flash's capacity, or a
    /// read / write size that does not divide the store's 64-byte chunk.
    Geometry,
    /// The payload is longer than [`MAX_LEN`](crate::MAX_LEN) or than a page can hold.
    TooLong {
        /// The payload's length \[bytes].
        len: usize,
    },
    /// The newest valid record has another format version than the store was built for.
    FormatVersion {
        /// The record's version.
        found: u16,
        /// The version the store expects.
        expected: u16,
    },
    /// The record written did not read back as written.
    Verify,
    /// The sequence number cannot grow any more (2³² saves: never in a flash's life).
    SequenceExhausted,
}

impl StoreError {
    /// A short name of the error, for a log or a link's answer.
    pub const fn name(&self) -> &'static str {
        match self {
            StoreError::Flash(_) => "flash",
            StoreError::Geometry => "geometry",
            StoreError::TooLong { .. } => "too_long",
            StoreError::FormatVersion { .. } => "format_version",
            StoreError::Verify => "verify",
            StoreError::SequenceExhausted => "sequence_exhausted",
        }
    }
}

/// The store's error for a flash driver's error (`map_err(flash_error)`).
pub(crate) fn flash_error<E: embedded_storage::nor_flash::NorFlashError>(e: E) -> StoreError {
    StoreError::Flash(e.kind())
}
