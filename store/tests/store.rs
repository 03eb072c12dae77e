//! The store on a RAM flash with the STM32G431's geometry: a save reads back, the newest
//! record wins, a torn save (the power cut at every double-word of it, or during the page
//! erase) leaves the record before it or the new one and never an error, a flipped bit
//! makes the older record win, another format version is named, bad sizes are refused.

mod common;

use common::{RamFlash, PAGE};
use pmsm_store::{Store, StoreError, HEADER_LEN, MAX_LEN};

const VERSION: u16 = 3;
const STORE: Store = Store::new(0, 2, VERSION);

/// Deterministic payload `k` of `len` bytes.
fn payload(k: u32, len: usize) -> Vec<u8> {
    (0..len)
        .map(|i| (k.wrapping_mul(2_654_435_761).wrapping_add(i as u32 * 97) >> 7) as u8)
        .collect()
}

/// A small deterministic generator (64-bit LCG, Knuth's MMIX constants).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 33) as usize) % n
    }
}

fn loaded(flash: &mut RamFlash<2>) -> Option<(u32, Vec<u8>)> {
    STORE
        .load(flash)
        .expect("load never fails on a readable flash")
        .map(|r| (r.seq(), r.bytes().to_vec()))
}

#[test]
fn empty_flash_holds_no_record() {
    let mut flash = RamFlash::<2>::new();
    assert!(STORE.load(&mut flash).unwrap().is_none());
    let s = STORE.summary(&mut flash).unwrap();
    assert_eq!((s.valid, s.skipped, s.newest), (0, 0, None));
}

#[test]
fn a_save_reads_back_and_the_newest_wins() {
    let mut flash = RamFlash::<2>::new();
    for (k, len) in [
        (1u32, 0usize),
        (2, 1),
        (3, 7),
        (4, 8),
        (5, 200),
        (6, MAX_LEN),
        (7, 33),
    ] {
        let seq = STORE.save(&mut flash, &payload(k, len)).unwrap();
        assert_eq!(seq, k);
        assert_eq!(loaded(&mut flash), Some((k, payload(k, len))));
    }
    assert_eq!(
        flash.total_erases(),
        0,
        "7 saves, 888 bytes: in the first page"
    );
}

#[test]
fn saves_of_every_length_read_back_across_page_changes() {
    let mut flash = RamFlash::<2>::new();
    let mut rng = Lcg(7);
    for k in 1..=300u32 {
        let bytes = payload(k, rng.next(MAX_LEN + 1));
        assert_eq!(STORE.save(&mut flash, &bytes).unwrap(), k);
        assert_eq!(loaded(&mut flash), Some((k, bytes)));
    }
}

/// A torn save: `budget` bytes programmed, then the power cut. After it the store holds
/// `before` or the new record, never an error; the next save works and wins.
fn torn_save(flash: &mut RamFlash<2>, before: &Option<(u32, Vec<u8>)>, new: &[u8], budget: usize) {
    flash.budget = Some(budget);
    let r = STORE.save(flash, new);
    flash.restore_power();
    let after = loaded(flash);
    match r {
        Ok(seq) => assert_eq!(after, Some((seq, new.to_vec()))),
        // The cut may fall after the record's last payload byte (in its padding): then the
        // save failed but its record is whole.
        Err(e) => {
            assert_eq!(e.name(), "flash", "{e:?}");
            let whole = after.as_ref().is_some_and(|(_, b)| b == new);
            assert!(&after == before || whole, "a cut after {budget} bytes");
        }
    }
    let next = payload(0xC0DE + budget as u32, 40);
    let seq = STORE.save(flash, &next).unwrap();
    assert_eq!(loaded(flash), Some((seq, next)));
}

#[test]
fn a_save_cut_at_any_double_word_leaves_the_old_record_or_the_new() {
    for garbage in [false, true] {
        let len = 100;
        let span = (HEADER_LEN + len).div_ceil(8) * 8;
        // The power cut at every byte of the record (inside a double-word too).
        for budget in 0..=span {
            let mut flash = RamFlash::<2>::new();
            flash.torn_garbage = garbage;
            STORE.save(&mut flash, &payload(1, 60)).unwrap();
            let before = loaded(&mut flash);
            torn_save(&mut flash, &before, &payload(2, len), budget);
        }
    }
}

#[test]
fn a_save_cut_while_moving_to_the_next_page_keeps_the_old_record() {
    for garbage in [false, true] {
        for budget in (0..=528).step_by(8).chain([3, 13, 21]) {
            let mut flash = RamFlash::<2>::new();
            flash.torn_garbage = garbage;
            // Page 0 full: 3 records of 512 bytes (528 each) and one of 400 (416).
            for k in 1..=3 {
                STORE.save(&mut flash, &payload(k, MAX_LEN)).unwrap();
            }
            STORE.save(&mut flash, &payload(4, 400)).unwrap();
            assert_eq!(flash.total_erases(), 0);
            let before = loaded(&mut flash);
            torn_save(&mut flash, &before, &payload(5, MAX_LEN), budget);
            assert!(flash.erases[1] >= 1, "the save moved to page 1");
        }
    }
}

#[test]
fn an_erase_cut_half_way_keeps_the_old_record() {
    let mut flash = RamFlash::<2>::new();
    // Fill page 0, move to page 1 and fill it: page 0 now holds the older records.
    let mut k = 0;
    while flash.erases[0] == 0 {
        k += 1;
        STORE.save(&mut flash, &payload(k, 300)).unwrap();
    }
    // The last save erased page 0 and wrote there; fill page 0 again until page 1 is next.
    let e1 = flash.erases[1];
    while flash.erases[1] == e1 {
        let before = loaded(&mut flash);
        k += 1;
        flash.cut_erase = true;
        let r = STORE.save(&mut flash, &payload(k, 300));
        flash.restore_power();
        if r.is_err() {
            // The page erase was cut: the page with the newest record is untouched.
            assert_eq!(loaded(&mut flash), before);
            let seq = STORE.save(&mut flash, &payload(k, 300)).unwrap();
            assert_eq!(loaded(&mut flash), Some((seq, payload(k, 300))));
            return;
        }
    }
    panic!("no save erased a page");
}

#[test]
fn a_flipped_bit_makes_the_older_record_win() {
    // In the newest record's payload, in its CRC, in its length, in its sequence number.
    for (at, bit) in [(HEADER_LEN + 5, 0u8), (12, 7), (6, 1), (9, 3)] {
        let mut flash = RamFlash::<2>::new();
        // Three records of 528 bytes fill page 0; the fourth starts page 1.
        for k in 1..=4 {
            STORE.save(&mut flash, &payload(k, MAX_LEN)).unwrap();
        }
        let newest_at = PAGE;
        assert_eq!(flash.erases[1], 1);
        flash.flip(newest_at + at, bit);
        let r = STORE.load(&mut flash).unwrap().unwrap();
        assert_eq!((r.seq(), r.bytes()), (3, &payload(3, MAX_LEN)[..]));
        assert!(r.skipped() <= 1, "byte {at} bit {bit}: {r:?}");
        // Page 0 (the valid newest's) is full: the next save erases page 1.
        let seq = STORE.save(&mut flash, &payload(9, 10)).unwrap();
        assert_eq!(loaded(&mut flash), Some((seq, payload(9, 10))));
    }
}

#[test]
fn a_record_after_a_torn_one_is_still_found() {
    let mut flash = RamFlash::<2>::new();
    STORE.save(&mut flash, &payload(1, 50)).unwrap();
    flash.budget = Some(40);
    assert!(STORE.save(&mut flash, &payload(2, 200)).is_err());
    flash.restore_power();
    // The next record is appended after the torn one's programmed bytes, in the same page.
    let seq = STORE.save(&mut flash, &payload(3, 50)).unwrap();
    assert_eq!(seq, 2);
    assert_eq!(flash.total_erases(), 0);
    let r = STORE.load(&mut flash).unwrap().unwrap();
    assert_eq!(
        (r.seq(), r.bytes(), r.skipped()),
        (2, &payload(3, 50)[..], 1)
    );
    let s = STORE.summary(&mut flash).unwrap();
    assert_eq!(
        (s.valid, s.skipped, s.newest),
        (2, 1, Some((2, VERSION, 50)))
    );
}

#[test]
fn another_format_version_is_named() {
    let mut flash = RamFlash::<2>::new();
    Store::new(0, 2, 2)
        .save(&mut flash, b"old settings")
        .unwrap();
    assert_eq!(
        STORE.load(&mut flash).unwrap_err(),
        StoreError::FormatVersion {
            found: 2,
            expected: VERSION
        }
    );
    // A save of the current version supersedes it.
    STORE.save(&mut flash, b"new settings").unwrap();
    assert_eq!(loaded(&mut flash), Some((2, b"new settings".to_vec())));
}

#[test]
fn bad_sizes_are_refused_and_change_nothing() {
    let mut flash = RamFlash::<4>::new();
    let too_long = [0u8; MAX_LEN + 1];
    assert_eq!(
        Store::new(0, 2, 1).save(&mut flash, &too_long),
        Err(StoreError::TooLong { len: MAX_LEN + 1 })
    );
    for store in [
        Store::new(0, 1, 1),
        Store::new(8, 2, 1),
        Store::new(PAGE as u32, 4, 1),
        Store::new(u32::MAX - 100, 2, 1),
    ] {
        assert_eq!(store.save(&mut flash, b"x"), Err(StoreError::Geometry));
        assert_eq!(store.load(&mut flash).unwrap_err(), StoreError::Geometry);
    }
    assert!(flash.mem.iter().all(|&b| b == 0xFF));
    assert_eq!((flash.writes, flash.total_erases()), (0, 0));
    // The last two pages of the four work.
    let store = Store::new(2 * PAGE as u32, 2, 1);
    store.save(&mut flash, b"x").unwrap();
    assert_eq!(store.load(&mut flash).unwrap().unwrap().bytes(), b"x");
    assert!(flash.mem[..2 * PAGE].iter().all(|&b| b == 0xFF));
}

#[test]
fn random_power_cuts_over_many_saves_never_lose_the_last_good_record() {
    let mut flash = RamFlash::<2>::new();
    flash.torn_garbage = true;
    let mut rng = Lcg(2026);
    let mut good: Option<(u32, Vec<u8>)> = None;
    for k in 0..2000u32 {
        let bytes = payload(k, rng.next(MAX_LEN + 1));
        if rng.next(3) == 0 {
            flash.budget = Some(rng.next(600));
        }
        if rng.next(50) == 0 {
            flash.cut_erase = true;
        }
        let r = STORE.save(&mut flash, &bytes);
        flash.restore_power();
        let now = loaded(&mut flash);
        match r {
            Ok(seq) => {
                assert_eq!(now, Some((seq, bytes)));
                good = now;
            }
            Err(_) => {
                let whole = now.as_ref().is_some_and(|(_, b)| *b == bytes);
                assert!(now == good || whole, "save {k}");
                if whole {
                    good = now;
                }
            }
        }
    }
}
