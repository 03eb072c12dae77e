//! The PLL's dividers for SYSCLK from a reference clock (RM0440 RCC_PLLCFGR; ranges of
//! DS12589's PLL characteristics): input `f_ref/M` within 2.66..8 MHz, VCO `input × N` within
//! 96..344 MHz, output `VCO/R` (R in 2, 4, 6, 8), N in 8..127, M in 1..16.

/// PLL input range \[Hz] (DS12589, PLL characteristics).
pub const INPUT_HZ: (u32, u32) = (2_660_000, 8_000_000);
/// VCO output range \[Hz] (DS12589).
pub const VCO_HZ: (u32, u32) = (96_000_000, 344_000_000);

/// The PLL's dividers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pll {
    /// Input divider M (1..16).
    pub m: u32,
    /// VCO multiplier N (8..127).
    pub n: u32,
    /// Output divider R (2, 4, 6, 8).
    pub r: u32,
    /// `f_ref/M` \[Hz].
    pub input_hz: u32,
    /// `input × N` \[Hz].
    pub vco_hz: u32,
    /// `VCO/R` \[Hz].
    pub out_hz: u32,
}

impl Pll {
    /// The dividers giving exactly `out_hz` from `ref_hz` with every frequency within its
    /// range: the smallest M (the highest input frequency: least jitter), then the smallest R.
    /// `None` if there is none.
    pub const fn exact(ref_hz: u32, out_hz: u32) -> Option<Self> {
        let mut m = 1;
        while m <= 16 {
            let input_hz = ref_hz / m;
            if ref_hz.is_multiple_of(m) && input_hz >= INPUT_HZ.0 && input_hz <= INPUT_HZ.1 {
                let mut r = 2;
                while r <= 8 {
                    let vco_hz = out_hz as u64 * r as u64;
                    let n = vco_hz / input_hz as u64;
                    if vco_hz.is_multiple_of(input_hz as u64)
                        && n >= 8
                        && n <= 127
                        && vco_hz >= VCO_HZ.0 as u64
                        && vco_hz <= VCO_HZ.1 as u64
                    {
                        return Some(Self {
                            m,
                            n: n as u32,
                            r,
                            input_hz,
                            vco_hz: vco_hz as u32,
                            out_hz,
                        });
                    }
                    r += 2;
                }
            }
            m += 1;
        }
        None
    }

    /// RCC_PLLCFGR with this PLL on `src` (PLLSRC\[1:0]: 2 = HSI16, 3 = HSE), only the R
    /// output enabled (PLLREN): PLLM\[7:4] = M − 1, PLLN\[14:8] = N, PLLREN bit 24,
    /// PLLR\[26:25] = R/2 − 1.
    pub const fn pllcfgr(&self, src: u32) -> u32 {
        src | (self.m - 1) << 4 | self.n << 8 | 1 << 24 | (self.r / 2 - 1) << 25
    }
}

/// PLLSRC of the HSI16 oscillator.
pub const SRC_HSI16: u32 = 2;
/// PLLSRC of the HSE oscillator.
pub const SRC_HSE: u32 = 3;

#[cfg(test)]
mod tests {
    use super::*;

    /// 170 MHz from the board's 8 MHz crystal and from HSI16: 4 MHz in, 340 MHz VCO, /2.
    #[test]
    fn board_pll() {
        for (ref_hz, m) in [(8_000_000, 2), (16_000_000, 4)] {
            let p = Pll::exact(ref_hz, 170_000_000).expect("a PLL setting");
            assert_eq!((p.m, p.n, p.r), (m, 85, 2));
            assert_eq!(p.input_hz, 4_000_000);
            assert_eq!(p.vco_hz, 340_000_000);
            assert!(p.input_hz >= INPUT_HZ.0 && p.input_hz <= INPUT_HZ.1);
            assert!(p.vco_hz >= VCO_HZ.0 && p.vco_hz <= VCO_HZ.1);
            assert_eq!(p.input_hz * p.n / p.r, 170_000_000);
        }
    }

    /// The register word, field by field (RM0440 RCC_PLLCFGR).
    #[test]
    fn pllcfgr_word() {
        let p = Pll::exact(8_000_000, 170_000_000).unwrap();
        let w = p.pllcfgr(SRC_HSE);
        assert_eq!(w & 0b11, 3);
        assert_eq!((w >> 4) & 0xF, 1);
        assert_eq!((w >> 8) & 0x7F, 85);
        assert_eq!((w >> 24) & 1, 1);
        assert_eq!((w >> 25) & 0b11, 0);
        assert_eq!(w, 0x0100_5513);
    }

    /// Out of range: no divider makes 171 MHz from 8 MHz within the VCO range with R = 2
    /// (N = 42.75), nor anything from a 1 MHz reference (input below 2.66 MHz).
    #[test]
    fn refusals() {
        assert!(Pll::exact(1_000_000, 170_000_000).is_none());
        let p = Pll::exact(8_000_000, 171_000_000);
        if let Some(p) = p {
            assert!(p.vco_hz <= VCO_HZ.1 && p.vco_hz >= VCO_HZ.0);
        }
    }
}
