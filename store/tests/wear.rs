//! The store's wear: over N saves a page is erased only when the current one is full, so
//! the erases are ⌈N / k⌉ − 1 with k = ⌊2048 / span⌋ records per page (span = 8 ⌈(16 + n) / 8⌉
//! for n payload bytes), shared evenly by the pages of the ring; a store that erased at every
//! save would erase N times. Run with `--nocapture` to see the counts.

mod common;

use common::{RamFlash, PAGE};
use pmsm_store::{Store, HEADER_LEN};

/// Saves `n` records of `len` bytes into a ring of `P` pages; returns the erases per page.
fn erases_over<const P: usize>(n: u32, len: usize) -> [u32; P] {
    let store = Store::new(0, P as u32, 1);
    let mut flash = RamFlash::<P>::new();
    for k in 0..n {
        let bytes: Vec<u8> = (0..len).map(|i| (k as usize + i) as u8).collect();
        store.save(&mut flash, &bytes).unwrap();
    }
    let r = store.load(&mut flash).unwrap().unwrap();
    assert_eq!(r.seq(), n);
    flash.erases
}

fn expected(n: u32, len: usize) -> u32 {
    let span = (HEADER_LEN + len).div_ceil(8) * 8;
    let per_page = (PAGE / span) as u32;
    n.div_ceil(per_page) - 1
}

#[test]
fn erases_only_when_a_page_is_full() {
    const N: u32 = 1000;
    for len in [24usize, 64, 200, 512] {
        let e = erases_over::<2>(N, len);
        let total: u32 = e.iter().sum();
        println!(
            "{N} saves of {len} B in 2 pages: {total} erases (pages {e:?}), formula {}",
            expected(N, len)
        );
        assert_eq!(total, expected(N, len));
        assert!(e[0].abs_diff(e[1]) <= 1, "pages share the erases: {e:?}");
    }
    // 200 B (a settings record of the link's size): 9 a page, 111 erases for 1000 saves.
    assert_eq!(erases_over::<2>(N, 200).iter().sum::<u32>(), 111);
}

#[test]
fn more_pages_share_the_erases() {
    let e = erases_over::<4>(1000, 200);
    println!("1000 saves of 200 B in 4 pages: erases {e:?}");
    assert_eq!(e.iter().sum::<u32>(), expected(1000, 200));
    assert!(e.iter().max().unwrap() - e.iter().min().unwrap() <= 1);
}
