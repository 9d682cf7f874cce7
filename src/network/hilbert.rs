//! Hilbert curve codes for the cells of an N×N grid (N a power of two).
//!
//! Consecutive codes are edge-adjacent cells, so cells close along the curve
//! are close in space: storing the grid's cell table in code order keeps the
//! segments of neighbouring cells close in memory (PAPERS.md §3.2).

/// Hilbert code of cell (`x`, `y`) in an `n`×`n` grid; `n` must be a power of
/// two and `x`, `y` < `n`. The result is in `0..n*n`.
pub fn xy_to_code(n: u32, mut x: u32, mut y: u32) -> u64 {
    debug_assert!(n.is_power_of_two() && x < n && y < n);
    let mut d: u64 = 0;
    let mut s = n / 2;
    while s > 0 {
        let rx = u32::from(x & s > 0);
        let ry = u32::from(y & s > 0);
        d += u64::from(s) * u64::from(s) * u64::from((3 * rx) ^ ry);
        rotate(n, &mut x, &mut y, rx, ry);
        s /= 2;
    }
    d
}

/// The cell (`x`, `y`) with Hilbert code `d` in an `n`×`n` grid (inverse of
/// [`xy_to_code`]); `d` must be below `n*n`. Only the tests need it.
#[cfg(test)]
pub fn code_to_xy(n: u32, d: u64) -> (u32, u32) {
    debug_assert!(n.is_power_of_two() && d < u64::from(n) * u64::from(n));
    let (mut x, mut y) = (0u32, 0u32);
    let mut t = d;
    let mut s = 1u32;
    while s < n {
        let rx = (1 & (t / 2)) as u32;
        let ry = (1 & (t ^ u64::from(rx))) as u32;
        rotate(s, &mut x, &mut y, rx, ry);
        x += s * rx;
        y += s * ry;
        t /= 4;
        s *= 2;
    }
    (x, y)
}

fn rotate(n: u32, x: &mut u32, y: &mut u32, rx: u32, ry: u32) {
    if ry == 0 {
        if rx == 1 {
            *x = n - 1 - *x;
            *y = n - 1 - *y;
        }
        std::mem::swap(x, y);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn order_two_curve() {
        // The first-order curve visits (0,0), (0,1), (1,1), (1,0).
        assert_eq!(xy_to_code(2, 0, 0), 0);
        assert_eq!(xy_to_code(2, 0, 1), 1);
        assert_eq!(xy_to_code(2, 1, 1), 2);
        assert_eq!(xy_to_code(2, 1, 0), 3);
    }

    #[test]
    fn bijection_exhaustive_small_grids() {
        for k in 0..=6 {
            let n = 1u32 << k;
            let mut seen = vec![false; (n * n) as usize];
            for x in 0..n {
                for y in 0..n {
                    let d = xy_to_code(n, x, y);
                    assert!(d < u64::from(n * n));
                    assert!(!seen[d as usize], "code {d} twice for n={n}");
                    seen[d as usize] = true;
                    assert_eq!(code_to_xy(n, d), (x, y));
                }
            }
        }
    }

    proptest! {
        #[test]
        fn bijection_large_grids(k in 0u32..16, x in any::<u32>(), y in any::<u32>()) {
            let n = 1u32 << k;
            let (x, y) = (x % n, y % n);
            let d = xy_to_code(n, x, y);
            prop_assert!(d < u64::from(n) * u64::from(n));
            prop_assert_eq!(code_to_xy(n, d), (x, y));
        }

        #[test]
        fn consecutive_codes_are_adjacent_cells(k in 1u32..16, d in any::<u64>()) {
            let n = 1u32 << k;
            let cells = u64::from(n) * u64::from(n);
            let d = d % (cells - 1);
            let (x0, y0) = code_to_xy(n, d);
            let (x1, y1) = code_to_xy(n, d + 1);
            prop_assert_eq!(x0.abs_diff(x1) + y0.abs_diff(y1), 1);
        }
    }
}
