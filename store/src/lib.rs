//! The drive's configuration kept in reserved flash pages: one opaque byte record (the link's
//! serialised settings, at most [`MAX_LEN`] bytes), versioned and CRC-checked, appended for
//! wear. `no_std`, no heap, no panic; written against `embedded-storage`'s
//! [`NorFlash`](embedded_storage::nor_flash::NorFlash) so the board's flash, the emulator's
//! and the host tests' RAM mock all carry it.
//!
//! # Layout ([`layout`])
//! Each record is a 16-byte header (magic, format version, length, sequence number, CRC-32 of
//! the header's first 12 bytes and the payload), then the payload, padded with the erased
//! value `0xFF` to the flash's write granularity. Records are appended one after another in a
//! page; the header is programmed first.
//!
//! # Wear ([`Store::save`])
//! A save appends its record to the page holding the newest record. Only when that page has
//! no room left does the save move to the next page of the region (two or more pages,
//! alternated in a ring), erase it, and write the record at its start: a page is erased once
//! per `page / record` saves, not once per save, and the pages share the erases. The page
//! holding the newest record is never erased, so a power cut during an erase or a write
//! loses at most the record being written, never the one before it.
//!
//! # Reading back ([`Store::load`])
//! Every page is scanned; a header is believed only when its CRC matches. The newest valid
//! record (highest sequence number) wins; a torn record (power cut mid-write), a bit flip or
//! any other bad-CRC record is skipped (counted in [`Record::skipped`]) and the older record
//! is used. A valid record of another format version is reported as
//! [`StoreError::FormatVersion`], not decoded.
//!
//! # On the STM32G431 (B-G431B-ESC1)
//! RM0440 §3.3 (embedded flash memory, single-bank mode of the 128 KiB part): pages of
//! 2 KiB, erased to `0xFF`, programmed one 64-bit double-word at a time (the ECC is per
//! double-word), and a double-word can be programmed only once after an erase. So the
//! board's `NorFlash` has `WRITE_SIZE = 8`, `ERASE_SIZE = 2048`, `READ_SIZE = 1`, and this
//! store never programmes a double-word twice: every record starts on an 8-byte boundary,
//! its padding to the next one is written with it, and a save checks that its target is
//! still erased (the page's used part ends at its last non-`0xFF` double-word). A region of
//! two pages (4 KiB, e.g. the last two of the 128 KiB: offsets 0x1_F000 and 0x1_F800) is
//! kept out of the image by the linker script. A record of `n` payload bytes takes
//! `8 ⌈(16 + n) / 8⌉` bytes: 9 records of 200 bytes fit a page, so 1000 saves of them erase
//! ⌈1000 / 9⌉ − 1 = 111 pages (measured in `tests/wear.rs`), against 1000 for a store that
//! erases at every save; at the part's 10 000 erase cycles per page (datasheet DS12589)
//! that is about 180 000 saves for the two pages.
//!
//! A double-word whose programming is interrupted reads back with an ECC error on the
//! STM32G4 (FLASH_ECCR, a bus fault or NMI on a double ECC error): the board's `read` must
//! turn that into an error or `0x00` bytes, not a fault, for a torn record to be skipped as
//! here. The QEMU emulator's flash (`examples/qemu-m4f`) has the same geometry.
#![no_std]
#![forbid(unsafe_code)]

mod error;
pub mod layout;
mod scan;
mod store;

pub use error::StoreError;
pub use layout::{HEADER_LEN, MAX_LEN};
pub use store::{Record, Store, Summary};
