//! A stand-in for the link's server until `pmsm_link::Server` is plugged in (main.rs says
//! where): frames of bytes ended by `0x00`, the first byte the request, answered with one
//! frame. Enough to test the UART, the store and their persistence end to end
//! (`scripts/link_e2e.py`); the bytes of a frame cannot hold `0x00` (no COBS here).
//!
//! | request        | answer                                              |
//! |----------------|-----------------------------------------------------|
//! | `E` bytes      | `E` bytes (echo)                                    |
//! | `S` bytes      | `S` and the record's sequence number, or `!` error  |
//! | `L`            | `L` and the stored record, `N` if none, `!` error   |
//! | `T`            | `T` and the drive's status (`off` if not driving)   |
//! | `R`            | none: the system resets (SYSRESETREQ)               |
//! | anything else  | `?`                                                 |
//!
//! A frame longer than [`MAX_FRAME`] bytes is dropped up to its end and answered `!long`.

use core::fmt::Write as _;
use embedded_io::{Read, ReadReady, Write};
use pmsm_store::{Store, MAX_LEN};

use crate::flash::SemihostedFlash;

/// The longest request \[bytes]: a request byte and a record.
pub const MAX_FRAME: usize = 1 + MAX_LEN;

/// What the drive shows the link.
#[derive(Debug, Clone, Copy)]
pub struct Status {
    /// Whether the drive runs (a valid configuration was loaded at boot).
    pub driving: bool,
    /// The rotor's speed \[rpm] (the plant's).
    pub speed_rpm: f32,
    /// The drive's latched fault, if any.
    pub fault: bool,
}

/// The stand-in server: the frame being received.
pub struct Placeholder {
    rx: [u8; MAX_FRAME],
    len: usize,
    overlong: bool,
}

/// An answer being built (at most a request byte and a record).
struct Answer {
    buf: [u8; 1 + MAX_LEN],
    len: usize,
}

impl Answer {
    fn new(kind: u8) -> Self {
        let mut a = Answer {
            buf: [0; 1 + MAX_LEN],
            len: 0,
        };
        a.push(&[kind]);
        a
    }

    fn push(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
        }
    }

    fn bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }
}

impl core::fmt::Write for Answer {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.push(s.as_bytes());
        Ok(())
    }
}

/// What a request asks beyond its answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum After {
    Nothing,
    Reset,
}

impl Placeholder {
    pub const fn new() -> Self {
        Placeholder {
            rx: [0; MAX_FRAME],
            len: 0,
            overlong: false,
        }
    }

    /// Reads what `io` has ready (without waiting), answers each complete frame.
    pub fn poll<U>(
        &mut self,
        io: &mut U,
        flash: &mut SemihostedFlash,
        store: &Store,
        status: &Status,
    ) -> Result<After, U::Error>
    where
        U: Read + Write + ReadReady,
    {
        let mut chunk = [0u8; 64];
        while io.read_ready()? {
            let n = io.read(&mut chunk)?;
            for &b in chunk.get(..n).unwrap_or(&[]) {
                if b != 0 {
                    match self.rx.get_mut(self.len) {
                        Some(slot) => {
                            *slot = b;
                            self.len += 1;
                        }
                        None => self.overlong = true,
                    }
                    continue;
                }
                let answer = if self.overlong {
                    let mut a = Answer::new(b'!');
                    a.push(b"long");
                    a
                } else {
                    let frame = self.rx.get(..self.len).unwrap_or(&[]);
                    if frame == b"R" {
                        return Ok(After::Reset);
                    }
                    answer(frame, flash, store, status)
                };
                self.len = 0;
                self.overlong = false;
                io.write_all(answer.bytes())?;
                io.write_all(&[0])?;
            }
        }
        Ok(After::Nothing)
    }
}

fn answer(frame: &[u8], flash: &mut SemihostedFlash, store: &Store, status: &Status) -> Answer {
    match frame.split_first() {
        Some((b'E', rest)) => {
            let mut a = Answer::new(b'E');
            a.push(rest);
            a
        }
        Some((b'S', rest)) => match store.save(flash, rest) {
            Ok(seq) => {
                defmt::info!(
                    "link: record {=u32} saved ({=usize} bytes)",
                    seq,
                    rest.len()
                );
                let mut a = Answer::new(b'S');
                let _ = write!(a, "{seq}");
                a
            }
            Err(e) => error(e.name()),
        },
        Some((b'L', _)) => match store.load(flash) {
            Ok(Some(r)) => {
                let mut a = Answer::new(b'L');
                a.push(r.bytes());
                a
            }
            Ok(None) => Answer::new(b'N'),
            Err(e) => error(e.name()),
        },
        Some((b'T', _)) => {
            let mut a = Answer::new(b'T');
            if status.driving {
                let _ = write!(
                    a,
                    "run {} rpm{}",
                    libm::roundf(status.speed_rpm) as i32,
                    if status.fault { " fault" } else { "" }
                );
            } else {
                a.push(b"off");
            }
            a
        }
        _ => Answer::new(b'?'),
    }
}

fn error(name: &str) -> Answer {
    let mut a = Answer::new(b'!');
    a.push(name.as_bytes());
    a
}
