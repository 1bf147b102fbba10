//! Thin structures: the votes near a pixel's own value that are joined to it.
//!
//! Thin structures (poles, wires, one to three pixels wide) fill a small part of any
//! square window, so the colour weights of the much larger background around them
//! outweigh them wherever their colour is close to the background's (dim, low-contrast,
//! noisy): the median erases what the EPI stage and the refinement found. What sets such
//! a structure apart in the disparity map is its shape: the pixels of its value, joined
//! to one another, cross the window and are narrow. A band that fattening carried across
//! a colour edge is joined to the object it came from (wide), and the blotches a faint
//! texture leaves are short, so neither passes (`pixel.rs`, `keeps_structure`).
//!
//! The window's rows are bit masks (lane k: column `x − r + k`), and the joined set grows
//! by 8-connected dilation within the allowed lanes, sweeping down and up the rows until
//! nothing changes: a few dozen integer operations per sweep.

use super::SPAN;

/// The lanes of each of the first `rows` window rows joined to lane `lane` of row
/// `centre_row` through lanes set in `similar` (8-connected); empty when that lane is
/// not set itself.
pub(super) fn connected(
    similar: &[u16; SPAN],
    rows: usize,
    centre_row: usize,
    lane: usize,
) -> [u16; SPAN] {
    let mut reach = [0u16; SPAN];
    let rows = rows.min(SPAN);
    let seed = similar
        .get(centre_row)
        .map_or(0, |&s| s & (1u16 << (lane & 15)));
    let Some(first) = reach.get_mut(centre_row) else {
        return reach;
    };
    *first = seed;
    if seed == 0 {
        return reach;
    }
    let dilate = |m: u16| m | (m << 1) | (m >> 1);
    loop {
        let mut changed = false;
        for i in (0..rows).chain((0..rows).rev()) {
            let above = i.checked_sub(1).and_then(|j| reach.get(j)).copied();
            let below = reach.get(i + 1).copied().filter(|_| i + 1 < rows);
            let (Some(row), Some(&allowed)) = (reach.get_mut(i), similar.get(i)) else {
                continue;
            };
            let mut m = (*row | dilate(above.unwrap_or(0)) | dilate(below.unwrap_or(0))) & allowed;
            // Along the row, through the runs of similar lanes that the seeds touch.
            loop {
                let grown = dilate(m) & allowed;
                if grown == m {
                    break;
                }
                m = grown;
            }
            if m != *row {
                *row = m;
                changed = true;
            }
        }
        if !changed {
            return reach;
        }
    }
}

/// Whether the lanes `reach` form an elongated, narrow set: its bounding box is at
/// least `length` long (rows or columns), and it holds at most `width` lanes per unit
/// of that length (a mean width of at most `width`).
pub(super) fn is_thin(reach: &[u16; SPAN], length: usize, width: f32) -> bool {
    let mut rows = reach
        .iter()
        .enumerate()
        .filter(|(_, &m)| m != 0)
        .map(|(i, _)| i);
    let first = rows.next();
    let rows_spanned = match (first, rows.next_back()) {
        (Some(a), Some(b)) => b - a + 1,
        (Some(_), None) => 1,
        _ => return false,
    };
    let columns = reach.iter().fold(0u16, |all, &m| all | m);
    let columns_spanned =
        16u32.saturating_sub(columns.leading_zeros() + columns.trailing_zeros()) as usize;
    let span = rows_spanned.max(columns_spanned);
    let size: u32 = reach.iter().map(|m| m.count_ones()).sum();
    span >= length && size as f32 <= width * span as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_vertical_line_is_joined_and_the_rest_is_not() {
        // A one-lane line at lane 7 of 15 rows, a blob at lanes 0..3 not touching it.
        let mut similar = [0u16; SPAN];
        for (i, s) in similar.iter_mut().enumerate() {
            *s = 1 << 7;
            if i < 4 {
                *s |= 0b111;
            }
        }
        let reach = connected(&similar, SPAN, 7, 7);
        assert!(reach.iter().all(|&m| m == 1 << 7));
    }

    #[test]
    fn a_diagonal_line_is_joined_through_corners() {
        let mut similar = [0u16; SPAN];
        for (i, s) in similar.iter_mut().enumerate() {
            *s = 1 << i;
        }
        let reach = connected(&similar, SPAN, 7, 7);
        assert_eq!(reach, similar);
        // A snake that turns back reaches every lane.
        let mut snake = [0u16; SPAN];
        snake[0] = 0x7fff;
        snake[1] = 1;
        snake[2] = 0x7fff;
        snake[3] = 1 << 14;
        snake[4] = 0x7fff;
        let reach = connected(&snake, 5, 4, 0);
        assert_eq!(reach[..5], snake[..5]);
        // Rows beyond `rows` are never reached, nor an unset seed.
        assert_eq!(connected(&snake, 3, 2, 0)[3..], [0u16; SPAN - 3]);
        assert_eq!(connected(&snake, 5, 1, 3), [0u16; SPAN]);
    }

    #[test]
    fn thin_means_long_and_narrow() {
        // A two-lane line down 15 rows: 30 lanes over a length of 15.
        let line = [0b11u16 << 6; SPAN];
        assert!(is_thin(&line, 8, 2.0));
        assert!(!is_thin(&line, 8, 1.9));
        assert!(!is_thin(&line, 16, 4.0));
        // Eight rows of it are long enough for 8, seven are not.
        let mut short = [0u16; SPAN];
        short[..8].fill(0b11 << 6);
        assert!(is_thin(&short, 8, 2.0));
        short[7] = 0;
        assert!(!is_thin(&short, 8, 4.0));
        // A diagonal is long both ways; a full row along the columns.
        let diagonal: [u16; SPAN] = core::array::from_fn(|i| 1 << i);
        assert!(is_thin(&diagonal, 15, 1.0));
        let mut row = [0u16; SPAN];
        row[3] = 0x7ff0;
        assert!(is_thin(&row, 11, 1.0));
        assert!(!is_thin(&row, 12, 1.0));
        // A square block is not thin at a width below its side.
        let block = [0xffu16; 8];
        let mut square = [0u16; SPAN];
        square[..8].copy_from_slice(&block);
        assert!(!is_thin(&square, 8, 7.9));
        assert!(is_thin(&square, 8, 8.0));
        assert!(!is_thin(&[0; SPAN], 1, 16.0));
    }
}
