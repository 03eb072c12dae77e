//! Reading the region back: the geometry check, the scan of every page for CRC-valid
//! records (the newest kept, the bad ones counted), the end of a page's used part, a
//! record's payload streamed through its CRC or into a buffer.

use embedded_storage::nor_flash::NorFlash;

use crate::error::{flash_error as flash_err, StoreError};
use crate::layout::{span, Header, CHUNK, ERASED, HEADER_LEN};

/// Where the store lives: `pages` pages of the flash's erase size from `base` (an offset in
/// the flash, on a page boundary).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Region {
    pub base: u32,
    pub pages: u32,
}

impl Region {
    /// The page size \[bytes] if the region and `F`'s sizes fit the store (see
    /// [`StoreError::Geometry`]).
    pub fn check<F: NorFlash>(&self, flash: &F) -> Result<u32, StoreError> {
        let (r, w, e) = (F::READ_SIZE, F::WRITE_SIZE, F::ERASE_SIZE);
        let sizes_ok = r >= 1
            && w >= 1
            && HEADER_LEN.is_multiple_of(r)
            && w.is_multiple_of(r)
            && CHUNK.is_multiple_of(w)
            && e.is_multiple_of(CHUNK)
            && e >= CHUNK;
        let page = u32::try_from(e).map_err(|_| StoreError::Geometry)?;
        let end = self
            .pages
            .checked_mul(page)
            .and_then(|n| n.checked_add(self.base));
        let region_ok = self.pages >= 2
            && self.base.is_multiple_of(page)
            && end.is_some_and(|end| end as usize <= flash.capacity());
        if sizes_ok && region_ok {
            Ok(page)
        } else {
            Err(StoreError::Geometry)
        }
    }

    /// The flash offset of page `p`.
    pub fn page_base(&self, p: u32, page: u32) -> u32 {
        self.base + p * page
    }
}

/// A CRC-valid record found in the region.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Found {
    /// Its page's index in the region.
    pub page: u32,
    /// Its flash offset.
    pub at: u32,
    /// Its header.
    pub header: Header,
}

/// What a scan of the region found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Scanned {
    /// The valid record of the highest sequence number.
    pub newest: Option<Found>,
    /// Valid records.
    pub valid: u16,
    /// Headers with the magic whose CRC does not match (torn, flipped) or that overrun
    /// their page.
    pub skipped: u16,
}

/// Scans every page of `region`: each position on the write grid holding a header with the
/// magic is checked against its CRC; a valid record is stepped over whole, anything else
/// one write unit at a time (so a record after a torn one is still found).
pub(crate) fn scan<F: NorFlash>(
    flash: &mut F,
    region: &Region,
    page: u32,
) -> Result<Scanned, StoreError> {
    let mut out = Scanned::default();
    let w = F::WRITE_SIZE as u32;
    for p in 0..region.pages {
        let base = region.page_base(p, page);
        let mut off = 0u32;
        while off + HEADER_LEN as u32 <= page {
            let at = base + off;
            if let Some(h) = Header::decode(&read_header(flash, at)?) {
                let len = span(usize::from(h.len), F::WRITE_SIZE) as u32;
                if off + len <= page && crc_ok(flash, at, &h)? {
                    out.valid = out.valid.saturating_add(1);
                    if out.newest.is_none_or(|n| h.seq > n.header.seq) {
                        out.newest = Some(Found {
                            page: p,
                            at,
                            header: h,
                        });
                    }
                    off += len;
                    continue;
                }
                out.skipped = out.skipped.saturating_add(1);
            }
            off += w;
        }
    }
    Ok(out)
}

/// The header bytes at flash offset `at`.
pub(crate) fn read_header<F: NorFlash>(
    flash: &mut F,
    at: u32,
) -> Result<[u8; HEADER_LEN], StoreError> {
    let mut b = [0u8; HEADER_LEN];
    flash.read(at, &mut b).map_err(flash_err)?;
    Ok(b)
}

/// Whether the payload after the header `h` at `at` matches its CRC.
pub(crate) fn crc_ok<F: NorFlash>(flash: &mut F, at: u32, h: &Header) -> Result<bool, StoreError> {
    let mut d = h.digest();
    for_payload(flash, at, h, |part, _| d.update(part))?;
    Ok(d.finalize() == h.crc)
}

/// Calls `f` on the payload of the record with header `h` at `at`, piece by piece, with each
/// piece's position in the payload; reads whole read units (the padding read, not passed).
pub(crate) fn for_payload<F: NorFlash>(
    flash: &mut F,
    at: u32,
    h: &Header,
    mut f: impl FnMut(&[u8], usize),
) -> Result<(), StoreError> {
    let len = usize::from(h.len);
    // The padded payload: a whole number of read units (READ_SIZE divides the header's
    // length and the write size, hence the span).
    let padded = span(len, F::WRITE_SIZE) - HEADER_LEN;
    let mut buf = [0u8; CHUNK];
    let mut done = 0usize;
    while done < padded {
        let n = (padded - done).min(CHUNK);
        let part = buf.get_mut(..n).ok_or(StoreError::Geometry)?;
        flash
            .read(at + (HEADER_LEN + done) as u32, part)
            .map_err(flash_err)?;
        let keep = len.saturating_sub(done).min(n);
        f(part.get(..keep).unwrap_or(&[]), done);
        done += n;
    }
    Ok(())
}

/// The end of page `p`'s used part (relative to the page, on the write grid): past its last
/// byte that is not erased. From there on the page can be programmed.
pub(crate) fn used_end<F: NorFlash>(
    flash: &mut F,
    region: &Region,
    p: u32,
    page: u32,
) -> Result<u32, StoreError> {
    let base = region.page_base(p, page);
    let mut buf = [0u8; CHUNK];
    let mut end = 0u32;
    let mut off = 0u32;
    while off < page {
        flash.read(base + off, &mut buf).map_err(flash_err)?;
        if let Some(i) = buf.iter().rposition(|&b| b != ERASED) {
            end = off + i as u32 + 1;
        }
        off += CHUNK as u32;
    }
    let w = F::WRITE_SIZE as u32;
    Ok(end.div_ceil(w) * w)
}
