//! The store's API: [`Store::load`] (the newest valid record) and [`Store::save`] (a new
//! record appended, a page erased only when the current one is full), [`Store::summary`]
//! for a status report.

use embedded_storage::nor_flash::NorFlash;

use crate::error::{flash_error, StoreError};
use crate::layout::{span, Header, CHUNK, ERASED, HEADER_LEN, MAX_LEN};
use crate::scan::{crc_ok, for_payload, read_header, scan, used_end, Region};

/// The configuration store: a region of two or more flash pages and the payload's format
/// version it reads and writes. Holds no flash: each call takes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Store {
    region: Region,
    version: u16,
}

/// A record read back: its payload (at most [`MAX_LEN`] bytes), sequence number and how
/// many bad records the scan passed over.
#[derive(Clone)]
pub struct Record {
    seq: u32,
    len: u16,
    skipped: u16,
    bytes: [u8; MAX_LEN],
}

impl Record {
    /// The payload.
    pub fn bytes(&self) -> &[u8] {
        self.bytes.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// The record's sequence number (one more at each save).
    pub fn seq(&self) -> u32 {
        self.seq
    }

    /// Headers with the store's magic and a bad CRC seen in the region (a torn save, a bit
    /// flip): not 0 says a save may have been lost and an older record used.
    pub fn skipped(&self) -> u16 {
        self.skipped
    }
}

impl core::fmt::Debug for Record {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Record")
            .field("seq", &self.seq)
            .field("skipped", &self.skipped)
            .field("bytes", &self.bytes())
            .finish()
    }
}

/// What a scan of the region found, for a status report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Summary {
    /// CRC-valid records (of any version).
    pub valid: u16,
    /// Headers with the magic and a bad CRC.
    pub skipped: u16,
    /// The newest valid record's sequence number, version and length \[bytes].
    pub newest: Option<(u32, u16, u16)>,
}

impl Store {
    /// A store of `pages` pages (of the flash's erase size, at least 2) from flash offset
    /// `base` (on a page boundary), for payloads of format `version`. Checked against the
    /// flash at each call ([`StoreError::Geometry`]).
    pub const fn new(base: u32, pages: u32, version: u16) -> Store {
        Store {
            region: Region { base, pages },
            version,
        }
    }

    /// The payload format version the store reads and writes.
    pub const fn version(&self) -> u16 {
        self.version
    }

    /// The newest valid record, `None` if the region holds none. A valid newest record of
    /// another version is [`StoreError::FormatVersion`]; bad records are skipped.
    pub fn load<F: NorFlash>(&self, flash: &mut F) -> Result<Option<Record>, StoreError> {
        let page = self.region.check(flash)?;
        let s = scan(flash, &self.region, page)?;
        let Some(found) = s.newest else {
            return Ok(None);
        };
        let h = found.header;
        if h.version != self.version {
            return Err(StoreError::FormatVersion {
                found: h.version,
                expected: self.version,
            });
        }
        let mut rec = Record {
            seq: h.seq,
            len: h.len,
            skipped: s.skipped,
            bytes: [0u8; MAX_LEN],
        };
        // Copied, then checked again: the bytes handed out are the ones the CRC covers.
        for_payload(flash, found.at, &h, |part, at| {
            if let Some(dst) = rec.bytes.get_mut(at..at + part.len()) {
                dst.copy_from_slice(part);
            }
        })?;
        let mut d = h.digest();
        d.update(rec.bytes());
        if d.finalize() != h.crc {
            return Err(StoreError::Verify);
        }
        Ok(Some(rec))
    }

    /// What the region holds (records valid and skipped, the newest's sequence number,
    /// version and length).
    pub fn summary<F: NorFlash>(&self, flash: &mut F) -> Result<Summary, StoreError> {
        let page = self.region.check(flash)?;
        let s = scan(flash, &self.region, page)?;
        Ok(Summary {
            valid: s.valid,
            skipped: s.skipped,
            newest: s
                .newest
                .map(|n| (n.header.seq, n.header.version, n.header.len)),
        })
    }

    /// Saves `bytes` as the newest record (sequence number one past the newest valid one)
    /// and returns its sequence number. Appended to the newest record's page where it fits
    /// after the page's used part; otherwise the next page of the ring is erased and the
    /// record written at its start. Read back and checked ([`StoreError::Verify`]).
    pub fn save<F: NorFlash>(&self, flash: &mut F, bytes: &[u8]) -> Result<u32, StoreError> {
        let page = self.region.check(flash)?;
        let len = bytes.len();
        let need = span(len, F::WRITE_SIZE) as u32;
        if len > MAX_LEN || need > page {
            return Err(StoreError::TooLong { len });
        }
        let s = scan(flash, &self.region, page)?;
        let (p, seq) = match s.newest {
            Some(n) => (
                n.page,
                n.header
                    .seq
                    .checked_add(1)
                    .ok_or(StoreError::SequenceExhausted)?,
            ),
            None => (0, 1),
        };
        let end = used_end(flash, &self.region, p, page)?;
        let at = if end + need <= page {
            self.region.page_base(p, page) + end
        } else {
            // The next page of the ring (p + 1 mod pages, without a division).
            let next = if p + 1 < self.region.pages { p + 1 } else { 0 };
            let base = self.region.page_base(next, page);
            flash.erase(base, base + page).map_err(flash_error)?;
            base
        };
        let h = Header::sealed(self.version, seq, bytes);
        write_record(flash, at, &h, bytes, need)?;
        let back = read_header(flash, at)?;
        if Header::decode(&back) != Some(h) || !crc_ok(flash, at, &h)? {
            return Err(StoreError::Verify);
        }
        Ok(seq)
    }
}

/// Programmes the record (`header`, `payload`, `0xFF` padding to `span` bytes) at `at` in
/// chunks, the header first: a power cut leaves a header whose CRC does not match.
fn write_record<F: NorFlash>(
    flash: &mut F,
    at: u32,
    header: &Header,
    payload: &[u8],
    span: u32,
) -> Result<(), StoreError> {
    let head = header.encode();
    let byte = |i: usize| -> u8 {
        if i < HEADER_LEN {
            head.get(i).copied().unwrap_or(ERASED)
        } else {
            payload.get(i - HEADER_LEN).copied().unwrap_or(ERASED)
        }
    };
    let mut buf = [ERASED; CHUNK];
    let mut done = 0usize;
    let span = span as usize;
    while done < span {
        let n = (span - done).min(CHUNK);
        let part = buf.get_mut(..n).ok_or(StoreError::Geometry)?;
        for (k, b) in part.iter_mut().enumerate() {
            *b = byte(done + k);
        }
        flash.write(at + done as u32, part).map_err(flash_error)?;
        done += n;
    }
    Ok(())
}
