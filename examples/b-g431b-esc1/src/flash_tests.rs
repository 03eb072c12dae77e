//! The flash driver on a zeroed FLASH block over a RAM region: bounds and alignment, the
//! double-words where the store asked for them, the unlock keys, the lock at the end, an
//! error flag reported.

use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
use stm32g4::stm32g431 as pac;

use super::*;
use crate::init_tests::{peek, poke, Zeroed};

/// A RAM region of [`SIZE`] bytes, erased, word-aligned.
fn region() -> Vec<u64> {
    vec![u64::MAX; SIZE / 8]
}

#[test]
fn the_region_is_the_last_two_pages() {
    assert_eq!(BASE_ADDR, 0x0801_F000);
    assert_eq!(FIRST_PAGE, 62);
}

#[test]
fn double_words_land_where_asked_and_the_flash_ends_locked() {
    let regs = Zeroed::<pac::flash::RegisterBlock>::new();
    poke(regs.rb().cr(), CR_LOCK);
    let mut mem = region();
    // SAFETY: `mem` is SIZE bytes, 8-aligned, alive for the test.
    let mut f = unsafe { ConfigFlash::at(regs.rb(), mem.as_mut_ptr() as *mut u8) };
    let data: Vec<u8> = (0..16u8).collect();
    f.write(2048 + 8, &data).unwrap();
    assert_eq!(peek(regs.rb().keyr()), KEY2, "unlocked with KEY1 then KEY2");
    assert_eq!(peek(regs.rb().cr()), CR_LOCK, "locked again");
    let mut back = [0u8; 24];
    f.read(2048, &mut back).unwrap();
    assert_eq!(&back[..8], &[0xFF; 8]);
    assert_eq!(&back[8..], &data[..]);
}

#[test]
fn off_grid_and_out_of_region_are_refused_untouched() {
    let regs = Zeroed::<pac::flash::RegisterBlock>::new();
    let mut mem = region();
    // SAFETY: as above.
    let mut f = unsafe { ConfigFlash::at(regs.rb(), mem.as_mut_ptr() as *mut u8) };
    assert_eq!(f.write(4, &[0; 8]), Err(FlashError::NotAligned));
    assert_eq!(f.write(0, &[0; 6]), Err(FlashError::NotAligned));
    assert_eq!(f.write(SIZE as u32, &[0; 8]), Err(FlashError::OutOfBounds));
    assert_eq!(f.erase(0, 100), Err(FlashError::NotAligned));
    assert_eq!(f.erase(0, 3 * PAGE as u32), Err(FlashError::OutOfBounds));
    assert_eq!(f.erase(PAGE as u32, 0), Err(FlashError::NotAligned));
    let mut b = [0u8; 2];
    assert_eq!(
        f.read(SIZE as u32 - 1, &mut b),
        Err(FlashError::OutOfBounds)
    );
    assert_eq!(peek(regs.rb().cr()), 0, "no register written");
    assert!(mem.iter().all(|&w| w == u64::MAX));
}

#[test]
fn an_erase_leaves_the_flash_locked_and_an_error_is_reported() {
    let regs = Zeroed::<pac::flash::RegisterBlock>::new();
    let mut mem = region();
    // SAFETY: as above.
    let mut f = unsafe { ConfigFlash::at(regs.rb(), mem.as_mut_ptr() as *mut u8) };
    f.erase(0, 2 * PAGE as u32).unwrap();
    assert_eq!(peek(regs.rb().cr()), CR_LOCK);
    // PROGERR (bit 3) standing: memory keeps it through the write-1-to-clear.
    poke(regs.rb().sr(), 1 << 3);
    assert_eq!(f.write(0, &[0; 8]), Err(FlashError::Hardware(1 << 3)));
    assert_eq!(peek(regs.rb().cr()), CR_LOCK);
}
