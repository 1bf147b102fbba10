//! Tests of the median: behaviour on small scenes, and equality, bit for bit, with a
//! direct reference implementation (every pixel weighs and selects its whole window, as
//! the stage did before the exact early test) on random maps and guides.

use super::*;
use crate::lightfield::{Grid, Layout};
use crate::setup::TestSetup;

mod random;
mod reference;
mod scenes;

fn stage_for(width: usize, height: usize, params: MedianParams) -> TestSetup<MedianParams> {
    let layout = Layout::packed(Grid::new(3, 3), width, height, 1);
    TestSetup::new(layout, params)
}
