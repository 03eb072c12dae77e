//! The configuration the link firmware keeps (feature `link`): the link's settings
//! (`pmsm_link::Settings`) serialised with postcard as the record of `pmsm-store` in the
//! configuration flash ([`crate::flash`]), the same record as the emulated firmware's
//! (`qemu-link/config.rs`, format [`CONFIG_VERSION`]). A record is put in force only when the
//! core accepts it (`Settings::validate`: `Motor::validate` and the drive's construction) and
//! this board can run it ([`crate::drive_settings::board_mismatch`]); else [`decode`] names
//! why and the board has no drive.

use pmsm_link::Settings;
use pmsm_store::{Store, MAX_LEN};

use crate::drive_settings::board_mismatch;

/// The stored record's format: `pmsm_link::Settings` as postcard encodes it (the emulated
/// firmware's `CONFIG_VERSION`: raise both when `Key::ALL` changes).
pub const CONFIG_VERSION: u16 = 2;
/// The store over the configuration region's two pages.
pub const STORE: Store = Store::new(0, 2, CONFIG_VERSION);

/// The settings of a stored record, validated by the core and fitting this board; the
/// field refused (or `"malformed record"`).
// `#[inline]`: compiled with the firmware's code that calls it; out of line in the
// library's, the link image came out 1.8 KB larger (the store's calls inlined differently).
#[inline]
pub fn decode(record: &[u8]) -> Result<Settings, &'static str> {
    let s: Settings = postcard::from_bytes(record).map_err(|_| "malformed record")?;
    s.validate().map_err(|e| e.field)?;
    match board_mismatch(&s.drive_config()) {
        Some(field) => Err(field),
        None => Ok(s),
    }
}

/// `settings` as the store's record in `buf`: the bytes to write.
#[inline]
pub fn encode<'a>(settings: &Settings, buf: &'a mut [u8; MAX_LEN]) -> Option<&'a [u8]> {
    postcard::to_slice(settings, buf).ok().map(|b| &*b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive_settings::{on_board, MOTOR};
    use crate::flash::{ConfigFlash, SIZE};
    use crate::init_tests::Zeroed;
    use pmsm_sensorless::drive::DriveConfig;
    use stm32g4::stm32g431 as pac;

    /// The board's motor on the board. Its rated power made rated torque times rated speed:
    /// `MOTOR` keeps the 48 V preset's 73 W with its speed lowered to 560 rpm (40.8 W), which
    /// `Motor::validate` refuses (`ratings.power_w`, beyond a factor 1.5), so a record of it
    /// would be refused at boot.
    fn board_settings() -> Settings {
        let mut m = MOTOR;
        m.ratings.power_w =
            m.ratings.torque_nm * m.ratings.speed_rpm * core::f32::consts::PI / 30.0;
        Settings::from(&on_board(DriveConfig::new(&m)))
    }

    #[test]
    fn a_record_of_the_boards_settings_comes_back_unchanged() {
        let s = board_settings();
        let mut buf = [0u8; MAX_LEN];
        let bytes = encode(&s, &mut buf).unwrap();
        assert_eq!(decode(bytes), Ok(s));
    }

    #[test]
    fn a_foreign_rate_a_bad_value_and_a_cut_record_are_named() {
        let mut buf = [0u8; MAX_LEN];
        let mut s = board_settings();
        s.rate_hz = 8000.0;
        assert_eq!(decode(encode(&s, &mut buf).unwrap()), Err("rate_hz"));
        let mut s = board_settings();
        s.motor.r_ohm = -1.0;
        let refused = decode(encode(&s, &mut buf).unwrap()).unwrap_err();
        assert!(refused.contains("r_ohm"), "{refused}");
        let n = encode(&board_settings(), &mut buf).unwrap().len();
        assert_eq!(decode(&buf[..n / 2]), Err("malformed record"));
    }

    #[test]
    fn saved_in_the_flash_region_loaded_back_and_a_bad_crc_skipped() {
        let regs = Zeroed::<pac::flash::RegisterBlock>::new();
        let mut mem = vec![u64::MAX; SIZE / 8];
        // SAFETY: `mem` is SIZE bytes, 8-aligned, alive for the test.
        let mut f = unsafe { ConfigFlash::at(regs.rb(), mem.as_mut_ptr() as *mut u8) };
        assert!(STORE.load(&mut f).unwrap().is_none(), "blank: no drive");
        let s = board_settings();
        let mut buf = [0u8; MAX_LEN];
        STORE.save(&mut f, encode(&s, &mut buf).unwrap()).unwrap();
        let rec = STORE.load(&mut f).unwrap().unwrap();
        assert_eq!(decode(rec.bytes()), Ok(s));
        // A second record, then its payload's last double-word corrupted: the first again.
        let mut t = s;
        t.speed_bandwidth_hz *= 0.5;
        STORE.save(&mut f, encode(&t, &mut buf).unwrap()).unwrap();
        let newest = STORE.load(&mut f).unwrap().unwrap();
        assert_eq!(decode(newest.bytes()), Ok(t));
        let used = mem.iter().rposition(|&w| w != u64::MAX).unwrap();
        mem[used] ^= 1;
        // SAFETY: as above.
        let mut f = unsafe { ConfigFlash::at(regs.rb(), mem.as_mut_ptr() as *mut u8) };
        let rec = STORE.load(&mut f).unwrap().unwrap();
        assert_eq!(decode(rec.bytes()), Ok(s));
        assert_eq!(rec.skipped(), 1);
    }
}
