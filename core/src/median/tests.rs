//! Tests of the median: behaviour on small scenes, and equality, bit for bit, with an
//! independent reference written from the stage's definition (every pixel weighs,
//! sorts and selects its whole window) on random maps and guides.

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
