//! TIM1's break input filters (RM0440 TIMx_BDTR.BKF/BK2F): the shortest filter of at least
//! a given time, for the over-current comparators' view of the switching edges.

/// Break filters (RM0440 TIMx_BDTR.BKF/BK2F codes 0..15): (sampling divider of the timer
/// clock, consecutive samples N); codes 1..3 sample at f_CK_INT, the others at f_DTS
/// (= f_CK_INT with CKD = 0, as here).
pub const BREAK_FILTERS: [(u32, u32); 16] = [
    (0, 0),
    (1, 2),
    (1, 4),
    (1, 8),
    (2, 6),
    (2, 8),
    (4, 6),
    (4, 8),
    (8, 6),
    (8, 8),
    (16, 5),
    (16, 6),
    (16, 8),
    (32, 5),
    (32, 6),
    (32, 8),
];

/// The shortest break filter of at least `ns` at a timer clock of `timer_hz` (the code and
/// its time \[ns]); the longest (code 15) if none reaches it.
pub const fn break_filter(ns: u32, timer_hz: u32) -> (u32, f32) {
    let mut best = 15;
    let mut code = 15;
    while code >= 1 {
        let (div, n) = BREAK_FILTERS[code];
        let t = div as u64 * n as u64 * 1_000_000_000;
        let best_t = {
            let (d, m) = BREAK_FILTERS[best];
            d as u64 * m as u64 * 1_000_000_000
        };
        if t >= ns as u64 * timer_hz as u64 && t <= best_t {
            best = code;
        }
        code -= 1;
    }
    let (div, n) = BREAK_FILTERS[best];
    (best as u32, (div * n) as f32 * 1e9 / timer_hz as f32)
}
