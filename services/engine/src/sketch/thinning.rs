//! Thinning of the stroke mask to 1-pixel skeletons (Zhang & Suen).
//!
//! Between stroke detection and the Hough transform. A pen stroke is several pixels wide;
//! every pixel of it would vote in the Hough accumulator, and a thick stroke yields several
//! parallel segments. Its skeleton — the centre line, one pixel wide, with the stroke's
//! connectivity — votes once per position along the wall, so vote counts measure length.
//!
//! Algorithm: T. Y. Zhang and C. Y. Suen, "A fast parallel algorithm for thinning digital
//! patterns", Comm. ACM 27(3), 1984. With the 8 neighbours of `p` named clockwise from north
//! `P2 … P9`, `B(p)` the number of foreground neighbours and `A(p)` the number of 0→1
//! transitions in the cyclic sequence `P2, P3, …, P9, P2`, a pass deletes, all at once,
//! every foreground `p` with `2 ≤ B ≤ 6`, `A = 1` and
//! - first sub-iteration: `P2·P4·P6 = 0` and `P4·P6·P8 = 0` (south-east boundary);
//! - second sub-iteration: `P2·P4·P8 = 0` and `P2·P6·P8 = 0` (north-west boundary);
//!
//! until a pass deletes nothing. Each pass peels one pixel per side, so the number of passes
//! is about half the stroke width `s`; only foreground pixels are visited, so the cost is
//! `O(F · s)` for `F` stroke pixels.

/// Thins a row-major `w × h` mask in place to its Zhang–Suen skeleton. Pixels outside the
/// image count as background.
pub fn zhang_suen(mask: &mut [bool], w: usize, h: usize) {
    if mask.len() != w * h || w == 0 || h == 0 {
        return;
    }
    let mut candidates: Vec<usize> = (0..w * h).filter(|&i| mask[i]).collect();
    let mut to_delete = Vec::new();
    loop {
        let mut changed = false;
        for first in [true, false] {
            to_delete.clear();
            for &i in &candidates {
                if mask[i] && deletable(mask, w, h, i, first) {
                    to_delete.push(i);
                }
            }
            for &i in &to_delete {
                mask[i] = false;
            }
            changed |= !to_delete.is_empty();
        }
        if !changed {
            break;
        }
        candidates.retain(|&i| mask[i]);
    }
}

/// The Zhang–Suen deletion test for pixel `i` in sub-iteration `first` or second.
fn deletable(mask: &[bool], w: usize, h: usize, i: usize, first: bool) -> bool {
    let (x, y) = ((i % w) as i64, (i / w) as i64);
    let at = |dx: i64, dy: i64| -> bool {
        let (nx, ny) = (x + dx, y + dy);
        nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 && mask[ny as usize * w + nx as usize]
    };
    // P2 … P9, clockwise from north (v grows downwards).
    let p = [
        at(0, -1),
        at(1, -1),
        at(1, 0),
        at(1, 1),
        at(0, 1),
        at(-1, 1),
        at(-1, 0),
        at(-1, -1),
    ];
    let b = p.iter().filter(|&&q| q).count();
    if !(2..=6).contains(&b) {
        return false;
    }
    let a = (0..8).filter(|&k| !p[k] && p[(k + 1) % 8]).count();
    if a != 1 {
        return false;
    }
    let (p2, p4, p6, p8) = (p[0], p[2], p[4], p[6]);
    if first {
        // P2·P4·P6 = 0 and P4·P6·P8 = 0.
        !(p4 && p6 && (p2 || p8))
    } else {
        // P2·P4·P8 = 0 and P2·P6·P8 = 0.
        !(p2 && p8 && (p4 || p6))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thick_bar_becomes_one_pixel_line() {
        let (w, h) = (40, 11);
        let mut m = vec![false; w * h];
        for y in 3..8 {
            for x in 5..35 {
                m[y * w + x] = true;
            }
        }
        zhang_suen(&mut m, w, h);
        for x in 8..32 {
            let n = (0..h).filter(|&y| m[y * w + x]).count();
            assert_eq!(n, 1, "column {x}");
        }
    }

    #[test]
    fn single_pixels_and_empty_masks_survive() {
        let mut m = vec![false; 9];
        m[4] = true;
        zhang_suen(&mut m, 3, 3);
        assert!(m[4]);
        let mut e: Vec<bool> = vec![];
        zhang_suen(&mut e, 0, 0);
    }
}
