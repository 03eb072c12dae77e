//! The CMSDK APB UART of the emulated board (UART0 of QEMU `mps2-an386` at `0x4000_4000`,
//! 25 MHz APB clock) as an `embedded-io` byte stream: [`Read`], [`ReadReady`], [`Write`].
//! Polled, no interrupt: the main loop asks [`ReadReady::read_ready`] and reads only then,
//! so the control loop never waits on the link.
//!
//! Registers (ARM Ltd., "Cortex-M System Design Kit Technical Reference Manual", ARM DDI
//! 0479C, the APB UART chapter; modelled in QEMU's `hw/char/cmsdk-apb-uart.c`): DATA (0x000, the received
//! byte on read, the byte to send on write), STATE (0x004: bit 0 TX buffer full, bit 1 RX
//! buffer full, bits 2–3 TX/RX overrun, write 1 to clear), CTRL (0x008: bit 0 TX enable,
//! bit 1 RX enable, bits 2–5 interrupt enables), INTSTATUS/INTCLEAR (0x00C), BAUDDIV (0x010,
//! at least 16). One byte of buffer each way: QEMU hands the next received byte only after
//! DATA was read, so a poll drains what is there.

use core::convert::Infallible;
use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};

/// UART0's base address on `mps2-an386` (QEMU `hw/arm/mps2.c`).
pub const UART0_BASE: usize = 0x4000_4000;
/// The APB clock of the UARTs on `mps2-an386` \[Hz] (QEMU `hw/arm/mps2.c`, `SYSCLK_FRQ`).
pub const PCLK_HZ: u32 = 25_000_000;

const DATA: usize = 0x000;
const STATE: usize = 0x004;
const CTRL: usize = 0x008;
const INTSTATUS: usize = 0x00C;
const BAUDDIV: usize = 0x010;

const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const STATE_OVERRUNS: u32 = 0b1100;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;

/// A CMSDK APB UART, 8N1, polled.
pub struct CmsdkUart {
    base: usize,
    /// RX overruns seen (a byte lost because the previous one was not read in time).
    pub rx_overruns: u32,
}

impl CmsdkUart {
    /// UART0 at `baud` \[bit/s] (BAUDDIV = PCLK / baud, at least 16), TX and RX enabled, no
    /// interrupt.
    ///
    /// # Safety
    /// One `CmsdkUart` for UART0 in the program: it owns the peripheral's registers.
    pub unsafe fn uart0(baud: u32) -> Self {
        let u = CmsdkUart {
            base: UART0_BASE,
            rx_overruns: 0,
        };
        u.write_reg(CTRL, 0);
        u.write_reg(BAUDDIV, (PCLK_HZ / baud.max(1)).max(16));
        u.write_reg(STATE, STATE_OVERRUNS);
        u.write_reg(INTSTATUS, 0xF);
        u.write_reg(CTRL, CTRL_TX_EN | CTRL_RX_EN);
        u
    }

    fn read_reg(&self, off: usize) -> u32 {
        // SAFETY: an aligned 32-bit register of the UART this value owns (`uart0`).
        unsafe { core::ptr::read_volatile((self.base + off) as *const u32) }
    }

    fn write_reg(&self, off: usize, v: u32) {
        // SAFETY: as in `read_reg`.
        unsafe { core::ptr::write_volatile((self.base + off) as *mut u32, v) }
    }

    /// The received byte, if one is waiting (counts and clears an RX overrun).
    pub fn try_read_byte(&mut self) -> Option<u8> {
        let state = self.read_reg(STATE);
        if state & STATE_OVERRUNS != 0 {
            self.rx_overruns = self
                .rx_overruns
                .wrapping_add(u32::from(state & 0b1000 != 0));
            self.write_reg(STATE, STATE_OVERRUNS);
        }
        (state & STATE_RX_FULL != 0).then(|| self.read_reg(DATA) as u8)
    }

    /// Sends `b` if the TX buffer has room; whether it did.
    pub fn try_write_byte(&mut self, b: u8) -> bool {
        let free = self.read_reg(STATE) & STATE_TX_FULL == 0;
        if free {
            self.write_reg(DATA, u32::from(b));
        }
        free
    }
}

impl ErrorType for CmsdkUart {
    type Error = Infallible;
}

impl ReadReady for CmsdkUart {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.read_reg(STATE) & STATE_RX_FULL != 0)
    }
}

impl Read for CmsdkUart {
    /// Waits for the first byte (none if `buf` is empty), then takes the bytes already
    /// waiting without waiting again. Ask [`ReadReady::read_ready`] first not to wait.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let mut n = 0;
        while n < buf.len() {
            match self.try_read_byte() {
                Some(b) => {
                    if let Some(slot) = buf.get_mut(n) {
                        *slot = b;
                    }
                    n += 1;
                }
                None if n > 0 => break,
                None => core::hint::spin_loop(),
            }
        }
        Ok(n)
    }
}

impl WriteReady for CmsdkUart {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.read_reg(STATE) & STATE_TX_FULL == 0)
    }
}

impl Write for CmsdkUart {
    /// Waits for room for the first byte, then sends what fits without waiting again (under
    /// QEMU the buffer empties at once unless the host socket pushes back).
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        let mut n = 0;
        for &b in buf {
            while !self.try_write_byte(b) {
                if n > 0 {
                    return Ok(n);
                }
                core::hint::spin_loop();
            }
            n += 1;
        }
        Ok(n)
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        while self.read_reg(STATE) & STATE_TX_FULL != 0 {
            core::hint::spin_loop();
        }
        Ok(())
    }
}
