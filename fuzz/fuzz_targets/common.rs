//! Shared by the stage targets: small random light fields and random parameters drawn
//! through the options table (so every tunable, band and tile size is reachable).

use lfdepth::epi::DisparityRange;
use lfdepth::options::{self, Kind, Value, TUNABLES};
use lfdepth::{Grid, Layout, Params, Preset};
use libfuzzer_sys::arbitrary::{self, Arbitrary};

/// Whole-number tunables are drawn from their first this many values, so that
/// iteration counts stay small enough for a fuzzer (every band and tile size down to
/// the smallest is still reached).
const INT_SPAN: usize = 48;

/// A value for one tunable: mostly inside its range, sometimes any bit pattern.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Pick {
    /// A fraction of the range (n / 255), a count, a name or a switch.
    InRange(u8),
    /// Any float (NaN, infinities): the stages' `validate` must refuse what is out of range.
    AnyFloat(f32),
    /// A fixed disparity range in sixteenths of a pixel, possibly reversed.
    Range(i8, i8),
}

#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Setting {
    pub tunable: u8,
    pub pick: Pick,
}

fn value(kind: Kind, pick: Pick) -> Option<Value> {
    Some(match (kind, pick) {
        (Kind::Float { min, max, .. }, Pick::InRange(n)) => {
            let top = if max.is_finite() { max } else { min + 64.0 };
            Value::Float(min + (top - min) * f32::from(n) / 255.0)
        }
        (Kind::Float { .. }, Pick::AnyFloat(x)) => Value::Float(x),
        (Kind::Int { min, max }, Pick::InRange(n)) => {
            let span = (max - min).saturating_add(1).min(INT_SPAN);
            Value::Int(min + usize::from(n) % span)
        }
        (Kind::Bool, Pick::InRange(n)) => Value::Bool(n & 1 == 1),
        (Kind::Choice(names), Pick::InRange(n)) => {
            Value::Choice(names[usize::from(n) % names.len()])
        }
        (Kind::Range, Pick::InRange(_)) => Value::Range(DisparityRange::Auto),
        (Kind::Range, Pick::Range(a, b)) => Value::Range(DisparityRange::Fixed {
            min: f32::from(a) / 16.0,
            max: f32::from(b) / 16.0,
        }),
        (Kind::Range, Pick::AnyFloat(x)) => Value::Range(DisparityRange::Fixed { min: -x, max: x }),
        _ => return None,
    })
}

/// The preset with the settings applied in order (settings of the wrong type skipped).
pub fn params(fast: bool, settings: &[Setting]) -> Params {
    let mut params = options::base(if fast { Preset::Fast } else { Preset::Default });
    for s in settings {
        let t = &TUNABLES[usize::from(s.tunable) % TUNABLES.len()];
        if let Some(v) = value(t.kind, s.pick) {
            let _ = t.apply(&mut params, v);
        }
    }
    params
}

/// A small light field: grid, size and channels, and how its views are made.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Shape {
    pub rows: u8,
    pub cols: u8,
    pub width: u8,
    pub height: u8,
    pub color: bool,
    /// Disparity between adjacent views in quarter pixels.
    pub disparity: i8,
    /// Texture seed.
    pub seed: u32,
    /// 0: a sheared texture (a real light field); otherwise noise of this amplitude on top.
    pub noise: u8,
}

impl Shape {
    /// The packed layout: grid 1…9 × 1…9, views 1…24 pixels a side.
    #[allow(dead_code)]
    pub fn layout(&self) -> Layout {
        self.layout_from(1)
    }

    /// The packed layout with views `least`…`least + 23` pixels a side.
    pub fn layout_from(&self, least: usize) -> Layout {
        Layout::packed(
            Grid::new(
                1 + usize::from(self.rows % 9),
                1 + usize::from(self.cols % 9),
            ),
            least + usize::from(self.width % 24),
            least + usize::from(self.height % 24),
            if self.color { 3 } else { 1 },
        )
    }

    /// The samples of [`Shape::layout`].
    #[allow(dead_code)]
    pub fn samples(&self) -> Vec<u8> {
        self.samples_for(self.layout())
    }

    /// The samples of `l` (one of this shape's layouts): a hashed texture seen by each
    /// view shifted by the disparity, plus noise.
    pub fn samples_for(&self, l: Layout) -> Vec<u8> {
        let (cr, cc) = (l.grid.rows as f32 / 2.0, l.grid.cols as f32 / 2.0);
        let d = f32::from(self.disparity.clamp(-12, 12)) / 4.0;
        let mut out = Vec::with_capacity(l.grid.len() * l.width * l.height * l.channels);
        let mut state = self.seed | 1;
        let mut rand = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        for r in 0..l.grid.rows {
            for c in 0..l.grid.cols {
                for y in 0..l.height {
                    for x in 0..l.width {
                        let sx = (x as f32 + d * (c as f32 - cc)).floor() as i32;
                        let sy = (y as f32 + d * (r as f32 - cr)).floor() as i32;
                        for ch in 0..l.channels {
                            let h = (sx as u32)
                                .wrapping_mul(0x9E37_79B1)
                                .wrapping_add((sy as u32).wrapping_mul(0x85EB_CA77))
                                .wrapping_add(ch as u32)
                                ^ self.seed;
                            let h = h ^ (h >> 15);
                            let base = (h.wrapping_mul(0x2C1B_3C6D) >> 24) as u8;
                            let noise = if self.noise == 0 {
                                0
                            } else {
                                (rand() % u32::from(self.noise)) as u8
                            };
                            out.push(base.wrapping_add(noise));
                        }
                    }
                }
            }
        }
        out
    }
}
