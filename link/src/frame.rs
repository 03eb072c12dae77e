//! Framing: one message per frame, `COBS(postcard(message) ‖ CRC-16(postcard(message))) ‖ 0x00`.
//!
//! - Consistent Overhead Byte Stuffing (S. Cheshire and M. Baker, "Consistent Overhead Byte
//!   Stuffing", IEEE/ACM Transactions on Networking 7(2), 1999): the frame's bytes contain no
//!   zero, so a zero ends a frame and a receiver that lost bytes finds the next frame at the
//!   next zero. Overhead one byte per 254 plus the terminator.
//! - The checksum is CRC-16/KERMIT (the CRC-16/CCITT of the catalogue: polynomial 0x1021,
//!   reflected, initial 0; `crc::CRC_16_KERMIT`), little-endian after the payload and inside
//!   the COBS encoding: any error burst of up to 16 bits in a frame is detected.
//! - The payload is the message serialised by postcard (varint integers, enum variants as their
//!   index): `docs.rs/postcard`'s wire format.
//!
//! [`FrameReader`] collects a byte stream into frames in a fixed buffer; a frame longer than
//! the buffer is discarded up to its terminator and reported once ([`FrameError::TooLong`]).

use serde::de::DeserializeOwned;
use serde::Serialize;

/// The CRC of every frame (module doc), computed bit by bit: a frame is at most a few hundred
/// bytes at 115 200 bit/s, and the 256-entry table would cost the board's image 512 B of flash.
const CRC16: crc::Crc<u16, crc::NoTable> = crc::Crc::<u16, crc::NoTable>::new(&crc::CRC_16_KERMIT);

/// Bytes of the checksum after the payload.
pub const CRC_LEN: usize = 2;

/// The largest payload (postcard bytes, without the checksum) of a frame \[bytes]: every
/// message of [`crate::msg`] fits (the largest, the whole `Settings`, is about 180 bytes).
pub const MAX_PAYLOAD: usize = 320;

/// The largest raw frame: the payload and its checksum.
pub const MAX_RAW: usize = MAX_PAYLOAD + CRC_LEN;

/// The largest encoded frame on the wire: the raw frame COBS-encoded, and its terminator.
pub const MAX_FRAME: usize = cobs::max_encoding_length(MAX_RAW) + 1;

/// Why a frame was not taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// More bytes than [`MAX_FRAME`] before the terminator.
    TooLong,
    /// Not a valid COBS encoding, or shorter than its checksum.
    Malformed,
    /// The checksum does not match the payload.
    BadChecksum,
    /// The checksum matches but the payload is no message of this protocol.
    Undecodable,
    /// The message does not fit in a frame (encoding).
    Overflow,
}

/// Encodes `msg` into `out` as one frame with its terminator; returns the frame's length.
pub fn encode<T: Serialize>(msg: &T, out: &mut [u8; MAX_FRAME]) -> Result<usize, FrameError> {
    let mut raw = [0u8; MAX_RAW];
    let n = postcard::to_slice(msg, &mut raw[..MAX_PAYLOAD])
        .map_err(|_| FrameError::Overflow)?
        .len();
    let crc = CRC16.checksum(&raw[..n]).to_le_bytes();
    raw[n..n + CRC_LEN].copy_from_slice(&crc);
    let len = cobs::try_encode(&raw[..n + CRC_LEN], &mut out[..MAX_FRAME - 1])
        .map_err(|_| FrameError::Overflow)?;
    out[len] = 0;
    Ok(len + 1)
}

/// The checked payload of one encoded frame (without its terminator), decoded in place in
/// `frame`: the payload's length.
pub fn payload(frame: &mut [u8]) -> Result<usize, FrameError> {
    let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Malformed)?;
    if n < CRC_LEN {
        return Err(FrameError::Malformed);
    }
    let body = n - CRC_LEN;
    let crc = u16::from_le_bytes([frame[body], frame[body + 1]]);
    if CRC16.checksum(&frame[..body]) != crc {
        return Err(FrameError::BadChecksum);
    }
    Ok(body)
}

/// The message of one encoded frame (without its terminator), decoded in place in `frame`.
pub fn decode<T: DeserializeOwned>(frame: &mut [u8]) -> Result<T, FrameError> {
    let n = payload(frame)?;
    postcard::from_bytes(&frame[..n]).map_err(|_| FrameError::Undecodable)
}

/// Collects a byte stream into frames, in a buffer of [`MAX_FRAME`] bytes.
pub struct FrameReader {
    buf: [u8; MAX_FRAME],
    len: usize,
    /// Bytes were dropped since the last terminator: the frame is discarded at it.
    overflowed: bool,
}

impl Default for FrameReader {
    fn default() -> Self {
        Self::new()
    }
}

/// What one byte completed.
#[derive(Debug, PartialEq, Eq)]
pub enum Pushed<'a> {
    /// The frame goes on (or an empty frame, a lone terminator, was skipped).
    More,
    /// A frame ended: its encoded bytes, without the terminator (decode with [`payload`] or
    /// [`decode`]).
    Frame(&'a mut [u8]),
    /// A frame longer than the buffer ended; it was discarded.
    TooLong,
}

impl FrameReader {
    /// An empty reader.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            overflowed: false,
        }
    }

    /// Takes one byte of the stream.
    pub fn push(&mut self, byte: u8) -> Pushed<'_> {
        if byte != 0 {
            if self.len < MAX_FRAME {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflowed = true;
            }
            return Pushed::More;
        }
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.overflowed) {
            return Pushed::TooLong;
        }
        if len == 0 {
            return Pushed::More;
        }
        Pushed::Frame(&mut self.buf[..len])
    }

    /// Bytes of an unfinished frame held.
    pub fn pending(&self) -> usize {
        self.len
    }
}
