//! The record's layout in flash: a 16-byte header, the payload, padding to the write
//! granularity; the CRC-32 (ISO-HDLC, the one of Ethernet and zlib: `crc::CRC_32_ISO_HDLC`)
//! over the header's first 12 bytes and the payload.
//!
//! | bytes  | field   | meaning                                                    |
//! |--------|---------|------------------------------------------------------------|
//! | 0..4   | magic   | [`MAGIC`], little-endian: the store's layout               |
//! | 4..6   | version | the payload's format version (the caller's)                |
//! | 6..8   | len     | payload length \[bytes], at most [`MAX_LEN`]               |
//! | 8..12  | seq     | sequence number: each save one more than the newest        |
//! | 12..16 | crc     | CRC-32 of bytes 0..12 and the payload                      |
//!
//! Integers are little-endian. The padding after the payload is `0xFF` (the erased value)
//! and outside the CRC.

use crc::{Crc, Digest, NoTable, CRC_32_ISO_HDLC};

/// The header's length \[bytes].
pub const HEADER_LEN: usize = 16;
/// The longest payload \[bytes].
pub const MAX_LEN: usize = 512;
/// The store's magic ("PMS1" read as a little-endian `u32`): neither erased (`0xFFFF_FFFF`)
/// nor programmed-to-zero flash.
pub const MAGIC: u32 = u32::from_le_bytes(*b"PMS1");
/// The unit the store reads and writes in \[bytes]: the flash's read and write sizes must
/// divide it (the STM32G4's 8 does).
pub const CHUNK: usize = 64;
/// The erased value of NOR flash.
pub const ERASED: u8 = 0xFF;

/// The CRC without a lookup table: a record is checked at boot and at a save, so its
/// speed does not matter and 1 KiB of table is kept out of the board's flash.
const CRC: Crc<u32, NoTable> = Crc::<u32, NoTable>::new(&CRC_32_ISO_HDLC);

/// A record's header, decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// The payload's format version.
    pub version: u16,
    /// The payload's length \[bytes].
    pub len: u16,
    /// The sequence number.
    pub seq: u32,
    /// The CRC-32 the header claims.
    pub crc: u32,
}

impl Header {
    /// The header's 16 bytes.
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut b = [0u8; HEADER_LEN];
        let fields = [
            MAGIC.to_le_bytes(),
            [
                self.version.to_le_bytes()[0],
                self.version.to_le_bytes()[1],
                self.len.to_le_bytes()[0],
                self.len.to_le_bytes()[1],
            ],
            self.seq.to_le_bytes(),
            self.crc.to_le_bytes(),
        ];
        for (dst, src) in b.chunks_exact_mut(4).zip(fields.iter()) {
            dst.copy_from_slice(src);
        }
        b
    }

    /// The header in `b` if it carries the magic and a length of at most [`MAX_LEN`]
    /// (its CRC still to be checked against the payload).
    pub fn decode(b: &[u8; HEADER_LEN]) -> Option<Header> {
        let [m0, m1, m2, m3, v0, v1, l0, l1, s0, s1, s2, s3, c0, c1, c2, c3] = *b;
        let h = Header {
            version: u16::from_le_bytes([v0, v1]),
            len: u16::from_le_bytes([l0, l1]),
            seq: u32::from_le_bytes([s0, s1, s2, s3]),
            crc: u32::from_le_bytes([c0, c1, c2, c3]),
        };
        (u32::from_le_bytes([m0, m1, m2, m3]) == MAGIC && usize::from(h.len) <= MAX_LEN)
            .then_some(h)
    }

    /// A CRC digest fed with the header's first 12 bytes; the payload follows.
    pub fn digest(&self) -> Digest<'static, u32, NoTable> {
        let mut d = CRC.digest();
        let b = self.encode();
        d.update(b.get(..12).unwrap_or(&[]));
        d
    }

    /// The header of a record of `payload`, its CRC computed.
    pub fn sealed(version: u16, seq: u32, payload: &[u8]) -> Header {
        let mut h = Header {
            version,
            len: payload.len() as u16,
            seq,
            crc: 0,
        };
        let mut d = h.digest();
        d.update(payload);
        h.crc = d.finalize();
        h
    }
}

/// The bytes a record of `len` payload bytes takes with write size `write_size`: header,
/// payload and padding.
pub const fn span(len: usize, write_size: usize) -> usize {
    (HEADER_LEN + len).div_ceil(write_size) * write_size
}
