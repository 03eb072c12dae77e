//! The link's serial port: USART2 on the ST-LINK's virtual COM port, 8N1, polled, as an
//! `embedded-io` byte stream ([`Usart`]: `Read`, `ReadReady`, `Write`), in the style of the
//! emulated board's UART (`examples/qemu-m4f`, `qemu-link/uart.rs`). No interrupt: the main
//! loop asks `read_ready` and reads only then, so the control interrupts never wait on the
//! link.
//!
//! Pins: USART2_TX on PB3 and USART2_RX on PB4, alternate function 7 (DS12589's alternate
//! function table). The board routes these two to the ST-LINK/V2-1's virtual COM port; the
//! source at hand was the B-G431B-ESC1 port of NuttX (`boards/arm/stm32/b-g431b-esc1`,
//! README: "USART2 is accessible through J3 pads and ST LINK Virtual Console: USART2_TX -
//! PB3, USART2_RX - PB4"), not UM2516 itself: check it against UM2516's schematic.
//!
//! Registers (RM0440, USART chapter, FIFO disabled): BRR = f_ck / baud with OVER8 = 0; ISR
//! bit 5 RXNE (a byte in RDR), bit 7 TXE (TDR empty), bit 3 ORE (overrun, cleared by ICR bit
//! 3). The kernel clock is PCLK1 (RCC_CCIPR.USART2SEL = 00 after reset) = SYSCLK, APB1 not
//! divided (`clocks`).

use core::convert::Infallible;

use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};
use stm32g4::stm32g431 as pac;

use crate::config::SETTINGS;

/// The link's bit rate \[bit/s].
pub const BAUD: u32 = 115_200;
/// USART2's alternate function on PB3 and PB4 (DS12589).
pub const AF_USART2: u8 = 7;
/// PB3 (TX) and PB4 (RX).
pub const PIN_TX: usize = 3;
/// See [`PIN_TX`].
pub const PIN_RX: usize = 4;

const ISR_ORE: u32 = 1 << 3;
const ISR_RXNE: u32 = 1 << 5;
const ISR_TC: u32 = 1 << 6;
const ISR_TXE: u32 = 1 << 7;
const CR1_UE: u32 = 1 << 0;
const CR1_RE: u32 = 1 << 2;
const CR1_TE: u32 = 1 << 3;

/// BRR for `baud` from the kernel clock `f_ck_hz` (16× oversampling: f_ck / baud, rounded).
pub const fn brr(f_ck_hz: u32, baud: u32) -> u32 {
    (f_ck_hz + baud / 2) / baud
}

/// Enables USART2's clock, puts PB3/PB4 on it (AF7, RX pulled up so an unplugged line idles
/// high) and starts it at [`BAUD`], 8N1, TX and RX on, no interrupt.
pub fn init(rcc: &pac::rcc::RegisterBlock, gpiob: &pac::gpiob::RegisterBlock, usart: &Usart2Regs) {
    rcc.apb1enr1().modify(|_, w| w.usart2en().set_bit());
    gpiob.pupdr().modify(|_, w| w.pupdr4().pull_up());
    gpiob
        .afrl()
        .modify(|_, w| w.afrl3().set(AF_USART2).afrl4().set(AF_USART2));
    gpiob
        .moder()
        .modify(|_, w| w.moder3().alternate().moder4().alternate());
    // SAFETY: raw words of RM0440's layout: BRR's 16 bits, CR1's UE/RE/TE.
    usart.cr1().write(|w| unsafe { w.bits(0) });
    usart
        .brr()
        .write(|w| unsafe { w.bits(brr(SETTINGS.sysclk_hz, BAUD)) });
    usart
        .cr1()
        .write(|w| unsafe { w.bits(CR1_UE | CR1_RE | CR1_TE) });
}

/// USART2's register block (the PAC's USART1 layout).
pub type Usart2Regs = pac::usart1::RegisterBlock;

/// A started USART (see [`init`]) as a byte stream.
pub struct Usart<'a> {
    regs: &'a Usart2Regs,
    /// Bytes lost because one was not read in time (RX overruns).
    pub rx_overruns: u32,
}

impl<'a> Usart<'a> {
    /// The stream over `regs` (started by [`init`]).
    pub fn new(regs: &'a Usart2Regs) -> Self {
        Self {
            regs,
            rx_overruns: 0,
        }
    }

    /// The received byte, if one is waiting (counts and clears an overrun).
    pub fn try_read_byte(&mut self) -> Option<u8> {
        let isr = self.regs.isr().read().bits();
        if isr & ISR_ORE != 0 {
            self.rx_overruns = self.rx_overruns.wrapping_add(1);
            // SAFETY: ICR's ORECF, write 1 to clear.
            self.regs.icr().write(|w| unsafe { w.bits(ISR_ORE) });
        }
        (isr & ISR_RXNE != 0).then(|| self.regs.rdr().read().bits() as u8)
    }

    /// Sends `b` if TDR is empty; whether it did.
    pub fn try_write_byte(&mut self, b: u8) -> bool {
        let free = self.regs.isr().read().bits() & ISR_TXE != 0;
        if free {
            // SAFETY: TDR's 9 data bits; a byte.
            self.regs.tdr().write(|w| unsafe { w.bits(u32::from(b)) });
        }
        free
    }
}

impl ErrorType for Usart<'_> {
    type Error = Infallible;
}

impl ReadReady for Usart<'_> {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.regs.isr().read().bits() & ISR_RXNE != 0)
    }
}

impl Read for Usart<'_> {
    /// Waits for the first byte (none if `buf` is empty), then takes the bytes already
    /// waiting without waiting again. Ask `read_ready` first not to wait.
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

impl WriteReady for Usart<'_> {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.regs.isr().read().bits() & ISR_TXE != 0)
    }
}

impl Write for Usart<'_> {
    /// Waits for room for the first byte, then sends what fits without waiting again (one
    /// byte time, 87 µs at 115 200 bit/s, per byte: the control runs in its interrupts).
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

    /// Waits until the last byte has left the shift register (ISR.TC): what was written has
    /// reached the wire (a restart may follow).
    fn flush(&mut self) -> Result<(), Infallible> {
        while self.regs.isr().read().bits() & ISR_TC == 0 {
            core::hint::spin_loop();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::init_tests::{peek, poke, Zeroed};
    use embedded_io::{Read, Write};

    #[test]
    fn baud_within_half_a_percent() {
        let div = brr(SETTINGS.sysclk_hz, BAUD);
        assert_eq!(div, 1476);
        let actual = SETTINGS.sysclk_hz as f32 / div as f32;
        assert!((actual / BAUD as f32 - 1.0).abs() < 0.005, "{actual}");
    }

    #[test]
    fn init_writes_pins_and_port() {
        let rcc = Zeroed::<pac::rcc::RegisterBlock>::new();
        let gpiob = Zeroed::<pac::gpiob::RegisterBlock>::new();
        let usart = Zeroed::<Usart2Regs>::new();
        init(rcc.rb(), gpiob.rb(), usart.rb());
        assert_ne!(peek(rcc.rb().apb1enr1()) & (1 << 17), 0, "USART2EN");
        let moder = peek(gpiob.rb().moder());
        assert_eq!((moder >> 6) & 3, 2, "PB3 alternate");
        assert_eq!((moder >> 8) & 3, 2, "PB4 alternate");
        let afrl = peek(gpiob.rb().afrl());
        assert_eq!((afrl >> 12) & 0xF, 7);
        assert_eq!((afrl >> 16) & 0xF, 7);
        assert_eq!(peek(usart.rb().brr()), 1476);
        assert_eq!(peek(usart.rb().cr1()), CR1_UE | CR1_RE | CR1_TE);
    }

    #[test]
    fn bytes_in_and_out_overrun_counted() {
        let regs = Zeroed::<Usart2Regs>::new();
        let mut u = Usart::new(regs.rb());
        poke(regs.rb().isr(), ISR_TXE);
        assert_eq!(u.write(b"ab").unwrap(), 2);
        assert_eq!(peek(regs.rb().tdr()), u32::from(b'b'));
        poke(regs.rb().isr(), ISR_RXNE | ISR_ORE);
        poke(regs.rb().rdr(), u32::from(b'x'));
        let mut b = [0u8; 1];
        assert_eq!(u.read(&mut b).unwrap(), 1);
        assert_eq!(b[0], b'x');
        assert_eq!(u.rx_overruns, 1);
        // The transmission complete flag (not only an empty data register) ends a flush.
        poke(regs.rb().isr(), ISR_TC);
        assert_eq!(u.flush(), Ok(()));
    }
}
