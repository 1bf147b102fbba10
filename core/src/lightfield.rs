//! A light field borrowed from caller memory: a grid of views, never copied.
//!
//! Views are addressed by grid position `(row, col)`, row-major, and pixels by `(x, y)`
//! with `x` to the right and `y` down. Disparity sign (as in the HCI benchmark): a point
//! with disparity `d` at `(x, y)` in the centre view `(r0, c0)` appears in view `(r, c)`
//! at `(x − d·(c − c0), y − d·(r − r0))`.

use crate::error::{checked_product, Error, Result};

mod sealed {
    pub trait Sealed {}
    impl Sealed for u8 {}
    impl Sealed for f32 {}
}

/// A stored sample type: 8-bit (`u8`, 0…255) or floating point (`f32`, nominally 0…1).
pub trait Sample:
    sealed::Sealed + Copy + Default + PartialEq + core::fmt::Debug + Send + Sync + 'static
{
    /// Whether `Self` is `u8`: every sample is its own 8-bit [`Self::level`], so a
    /// kernel may look levels up in a table of 256, chosen at compile time.
    const IS_U8: bool;
    /// The sample as intensity in nominal `[0, 1]`.
    fn to_unit(self) -> f32;
    /// Whether every value of the type is finite (true for `u8`).
    fn is_finite(self) -> bool;
    /// The sample as an 8-bit level, rounded and clamped to 0…255 (NaN → 0): integer
    /// colour comparisons without floating point on `u8` data.
    fn level(self) -> u8;
    /// `N` samples as they are stored when `Self` is `u8`, `None` for `f32`: a
    /// kernel's 8-bit path, chosen at compile time (unlike [`Self::level`], no
    /// conversion).
    fn as_u8_lanes<const N: usize>(samples: &[Self; N]) -> Option<&[u8; N]>;
    /// [`Self::as_u8_lanes`] of one sample.
    fn as_u8(self) -> Option<u8>;
}

impl Sample for u8 {
    const IS_U8: bool = true;
    #[inline(always)]
    fn to_unit(self) -> f32 {
        self as f32 * (1.0 / 255.0)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        true
    }
    #[inline(always)]
    fn level(self) -> u8 {
        self
    }
    #[inline(always)]
    fn as_u8_lanes<const N: usize>(samples: &[Self; N]) -> Option<&[u8; N]> {
        Some(samples)
    }
    #[inline(always)]
    fn as_u8(self) -> Option<u8> {
        Some(self)
    }
}

impl Sample for f32 {
    const IS_U8: bool = false;
    #[inline(always)]
    fn to_unit(self) -> f32 {
        self
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline(always)]
    fn level(self) -> u8 {
        // `as` saturates and maps NaN to 0.
        (self * 255.0 + 0.5) as u8
    }
    #[inline(always)]
    fn as_u8_lanes<const N: usize>(_: &[Self; N]) -> Option<&[u8; N]> {
        None
    }
    #[inline(always)]
    fn as_u8(self) -> Option<u8> {
        None
    }
}

/// Smallest and largest supported number of views along either grid axis; a linear array
/// (one row or one column of cameras, [`Grid::is_linear`]) has one view along the other.
pub const GRID_MIN: usize = 3;
/// See [`GRID_MIN`].
pub const GRID_MAX: usize = 17;
/// Smallest supported view width and height in pixels.
pub const VIEW_MIN: usize = 16;

/// The arrangement of views: `rows` × `cols` cameras.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Grid {
    /// Views along the vertical camera axis.
    pub rows: usize,
    /// Views along the horizontal camera axis.
    pub cols: usize,
}

impl Grid {
    /// A grid of `rows` × `cols` views.
    pub const fn new(rows: usize, cols: usize) -> Self {
        Grid { rows, cols }
    }
    /// The reference ("centre") view. For an even count the lower middle index is used,
    /// so every view offset `c − c0` is an integer.
    pub const fn center(&self) -> (usize, usize) {
        ((self.rows - 1) / 2, (self.cols - 1) / 2)
    }
    /// Number of views.
    pub const fn len(&self) -> usize {
        self.rows * self.cols
    }
    /// Whether the grid has no views.
    pub const fn is_empty(&self) -> bool {
        self.rows == 0 || self.cols == 0
    }
    /// Index of view `(row, col)` in row-major order.
    pub const fn index(&self, row: usize, col: usize) -> usize {
        row * self.cols + col
    }
    /// Whether the views differ along the horizontal camera axis (more than one
    /// column): the horizontal EPIs exist.
    pub const fn has_horizontal_parallax(&self) -> bool {
        self.cols > 1
    }
    /// Whether the views differ along the vertical camera axis (more than one row):
    /// the vertical EPIs exist.
    pub const fn has_vertical_parallax(&self) -> bool {
        self.rows > 1
    }
    /// Whether the grid is one row or one column of cameras (a linear array, such as a
    /// camera rail): only one EPI direction exists.
    pub const fn is_linear(&self) -> bool {
        (self.rows == 1) != (self.cols == 1)
    }
    /// Whether the estimators take this grid: [`GRID_MIN`]…[`GRID_MAX`] views along
    /// each axis, or along one axis of a linear array (1×N or N×1).
    pub const fn is_supported(&self) -> bool {
        const fn fits(n: usize) -> bool {
            n >= GRID_MIN && n <= GRID_MAX
        }
        (fits(self.rows) || self.rows == 1)
            && (fits(self.cols) || self.cols == 1)
            && !(self.rows == 1 && self.cols == 1)
    }
}

/// Where each sample lives in a flat buffer. Strides are in elements (samples), not bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Layout {
    /// The view grid.
    pub grid: Grid,
    /// View width in pixels.
    pub width: usize,
    /// View height in pixels.
    pub height: usize,
    /// Samples per pixel: 1, 3 or 4 (a fourth channel is ignored by the estimators).
    pub channels: usize,
    /// Elements from the start of one image row to the next (≥ `width · channels`).
    pub row_stride: usize,
    /// Elements from the start of one view to the next, row-major over the grid
    /// (≥ `(height − 1) · row_stride + width · channels`).
    pub view_stride: usize,
}

impl Layout {
    /// Tightly packed views, one after another in row-major grid order.
    /// Sizes that overflow are caught later by [`Layout::validate`].
    pub fn packed(grid: Grid, width: usize, height: usize, channels: usize) -> Self {
        let row_stride = width.saturating_mul(channels);
        Layout {
            grid,
            width,
            height,
            channels,
            row_stride,
            view_stride: row_stride.saturating_mul(height),
        }
    }

    /// Checks dimensions and strides; returns the number of elements the buffer needs.
    pub fn validate(&self) -> Result<usize> {
        let Grid { rows, cols } = self.grid;
        if !self.grid.is_supported() {
            return Err(Error::GridSize { rows, cols });
        }
        if self.width < VIEW_MIN || self.height < VIEW_MIN {
            return Err(Error::ViewTooSmall {
                width: self.width,
                height: self.height,
            });
        }
        if !matches!(self.channels, 1 | 3 | 4) {
            return Err(Error::Channels {
                channels: self.channels,
            });
        }
        let row_len = checked_product(&[self.width, self.channels], "an image row")?;
        if self.row_stride < row_len {
            return Err(Error::Stride {
                which: "row stride",
                stride: self.row_stride,
                needed: row_len,
            });
        }
        let view_len = checked_product(&[self.height - 1, self.row_stride], "a view")?
            .checked_add(row_len)
            .ok_or(Error::SizeOverflow { what: "a view" })?;
        if self.view_stride < view_len {
            return Err(Error::Stride {
                which: "view stride",
                stride: self.view_stride,
                needed: view_len,
            });
        }
        checked_product(&[self.grid.len() - 1, self.view_stride], "the light field")?
            .checked_add(view_len)
            .ok_or(Error::SizeOverflow {
                what: "the light field",
            })
    }

    /// Number of pixels of one view (= elements of a disparity map).
    pub fn pixels(&self) -> usize {
        self.width * self.height
    }
}

/// A validated light field borrowed from caller memory.
#[derive(Clone, Copy, Debug)]
pub struct LightField<'a, S: Sample> {
    data: &'a [S],
    layout: Layout,
}

impl<'a, S: Sample> LightField<'a, S> {
    /// Validates `layout` against `data`. Extra trailing elements are allowed.
    pub fn new(data: &'a [S], layout: Layout) -> Result<Self> {
        let needed = layout.validate()?;
        if data.len() < needed {
            return Err(Error::BufferTooSmall {
                what: "the light-field buffer",
                needed,
                got: data.len(),
            });
        }
        Ok(LightField { data, layout })
    }

    /// The validated layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }
    /// The view grid.
    pub fn grid(&self) -> Grid {
        self.layout.grid
    }
    /// View width in pixels.
    pub fn width(&self) -> usize {
        self.layout.width
    }
    /// View height in pixels.
    pub fn height(&self) -> usize {
        self.layout.height
    }
    /// Samples per pixel.
    pub fn channels(&self) -> usize {
        self.layout.channels
    }
    /// The underlying buffer.
    pub fn data(&self) -> &'a [S] {
        self.data
    }

    /// Checks a view position.
    fn check_view(&self, row: usize, col: usize) -> Result<()> {
        let g = self.layout.grid;
        if row >= g.rows {
            return Err(Error::OutOfRange {
                what: "view row",
                index: row,
                len: g.rows,
            });
        }
        if col >= g.cols {
            return Err(Error::OutOfRange {
                what: "view column",
                index: col,
                len: g.cols,
            });
        }
        Ok(())
    }

    /// The view at grid position `(row, col)`.
    pub fn view(&self, row: usize, col: usize) -> Result<View<'a, S>> {
        self.check_view(row, col)?;
        // In bounds: validate() proved the last view ends inside `data`.
        let start = self.layout.grid.index(row, col) * self.layout.view_stride;
        Ok(View {
            data: self.data.get(start..).unwrap_or_default(),
            width: self.layout.width,
            height: self.layout.height,
            channels: self.layout.channels,
            row_stride: self.layout.row_stride,
        })
    }

    /// The centre (reference) view.
    pub fn center_view(&self) -> View<'a, S> {
        let (r, c) = self.layout.grid.center();
        // The centre of a validated grid always exists.
        match self.view(r, c) {
            Ok(v) => v,
            Err(_) => View::empty(),
        }
    }

    /// One sample, or `None` outside the light field.
    pub fn pixel(&self, row: usize, col: usize, x: usize, y: usize, channel: usize) -> Option<S> {
        self.view(row, col).ok()?.pixel(x, y, channel)
    }

    /// The horizontal EPI through view row `view_row` at image row `y`:
    /// `E(k, t)` is pixel `x = t` of view `(view_row, k)`.
    pub fn epi_horizontal(&self, view_row: usize, y: usize) -> Result<Epi<'a, S>> {
        self.check_view(view_row, 0)?;
        if y >= self.layout.height {
            return Err(Error::OutOfRange {
                what: "image row",
                index: y,
                len: self.layout.height,
            });
        }
        let start = self.layout.grid.index(view_row, 0) * self.layout.view_stride
            + y * self.layout.row_stride;
        Ok(Epi {
            data: &self.data[start..],
            views: self.layout.grid.cols,
            samples: self.layout.width,
            channels: self.layout.channels,
            view_step: self.layout.view_stride,
            sample_step: self.layout.channels,
        })
    }

    /// The vertical EPI through view column `view_col` at image column `x`:
    /// `E(k, t)` is pixel `y = t` of view `(k, view_col)`.
    pub fn epi_vertical(&self, view_col: usize, x: usize) -> Result<Epi<'a, S>> {
        self.check_view(0, view_col)?;
        if x >= self.layout.width {
            return Err(Error::OutOfRange {
                what: "image column",
                index: x,
                len: self.layout.width,
            });
        }
        let start = self.layout.grid.index(0, view_col) * self.layout.view_stride
            + x * self.layout.channels;
        Ok(Epi {
            data: &self.data[start..],
            views: self.layout.grid.rows,
            samples: self.layout.height,
            channels: self.layout.channels,
            view_step: self.layout.view_stride * self.layout.grid.cols,
            sample_step: self.layout.row_stride,
        })
    }
}

/// One view of a light field.
#[derive(Clone, Copy, Debug)]
pub struct View<'a, S: Sample> {
    data: &'a [S],
    width: usize,
    height: usize,
    channels: usize,
    row_stride: usize,
}

impl<'a, S: Sample> View<'a, S> {
    /// A view over caller memory: `height` rows of `width` pixels of `channels` samples,
    /// `row_stride` elements apart (e.g. the centre view of a band of rows held by a
    /// stream). Checks the channels, the stride and that `data` holds every row.
    pub fn new(
        data: &'a [S],
        width: usize,
        height: usize,
        channels: usize,
        row_stride: usize,
    ) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::ViewTooSmall { width, height });
        }
        if !matches!(channels, 1 | 3 | 4) {
            return Err(Error::Channels { channels });
        }
        let row_len = checked_product(&[width, channels], "an image row")?;
        if row_stride < row_len {
            return Err(Error::Stride {
                which: "row stride",
                stride: row_stride,
                needed: row_len,
            });
        }
        let needed = checked_product(&[height - 1, row_stride], "a view")?
            .checked_add(row_len)
            .ok_or(Error::SizeOverflow { what: "a view" })?;
        if data.len() < needed {
            return Err(Error::BufferTooSmall {
                what: "the view buffer",
                needed,
                got: data.len(),
            });
        }
        Ok(View {
            data,
            width,
            height,
            channels,
            row_stride,
        })
    }

    fn empty() -> Self {
        View {
            data: &[],
            width: 0,
            height: 0,
            channels: 1,
            row_stride: 0,
        }
    }
    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }
    /// Samples per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// Image row `y` as `width · channels` interleaved samples.
    pub fn row(&self, y: usize) -> Option<&'a [S]> {
        if y >= self.height {
            return None;
        }
        let start = y * self.row_stride;
        self.data.get(start..start + self.width * self.channels)
    }
    /// One sample, or `None` outside the view.
    pub fn pixel(&self, x: usize, y: usize, channel: usize) -> Option<S> {
        if x >= self.width || channel >= self.channels {
            return None;
        }
        self.row(y)?.get(x * self.channels + channel).copied()
    }
}

/// An epipolar-plane image: `views` rows (one per camera along the line) by `samples`
/// pixels, each with `channels` samples.
#[derive(Clone, Copy, Debug)]
pub struct Epi<'a, S: Sample> {
    data: &'a [S],
    views: usize,
    samples: usize,
    channels: usize,
    view_step: usize,
    sample_step: usize,
}

impl<'a, S: Sample> Epi<'a, S> {
    /// Number of views (the angular axis `k`).
    pub fn views(&self) -> usize {
        self.views
    }
    /// Number of pixels along the spatial axis `t`.
    pub fn samples(&self) -> usize {
        self.samples
    }
    /// Samples per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// Sample `channel` of pixel `t` in view `k`, or `None` outside the EPI.
    pub fn get(&self, k: usize, t: usize, channel: usize) -> Option<S> {
        if k >= self.views || t >= self.samples || channel >= self.channels {
            return None;
        }
        self.data
            .get(k * self.view_step + t * self.sample_step + channel)
            .copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_u8_samples_take_the_8_bit_paths() {
        assert_eq!(200u8.as_u8(), Some(200));
        assert_eq!(u8::as_u8_lanes(&[1u8, 2, 3]), Some(&[1, 2, 3]));
        assert_eq!(0.5f32.as_u8(), None);
        assert_eq!(f32::as_u8_lanes(&[0.5f32; 4]), None);
    }

    /// A 3×4 grid of 16×17 RGB views with padded rows and views, value-coded so each
    /// sample tells where it came from.
    fn coded() -> ([u8; 4 * 3 * 17 * 56 + 64], Layout) {
        let layout = Layout {
            grid: Grid::new(3, 4),
            width: 16,
            height: 17,
            channels: 3,
            row_stride: 50,
            view_stride: 17 * 56,
        };
        let mut data = [0u8; 4 * 3 * 17 * 56 + 64];
        for r in 0..3 {
            for c in 0..4 {
                for y in 0..17 {
                    for x in 0..16 {
                        for ch in 0..3 {
                            let i = (r * 4 + c) * layout.view_stride + y * 50 + x * 3 + ch;
                            data[i] = (r * 64 + c * 16 + ch * 4 + (x + y) % 4) as u8;
                        }
                    }
                }
            }
        }
        (data, layout)
    }

    fn code(r: usize, c: usize, x: usize, y: usize, ch: usize) -> u8 {
        (r * 64 + c * 16 + ch * 4 + (x + y) % 4) as u8
    }

    #[test]
    fn accessors_follow_strides() {
        let (data, layout) = coded();
        let lf = LightField::new(&data[..], layout).unwrap();
        assert_eq!(lf.pixel(2, 3, 15, 16, 2), Some(code(2, 3, 15, 16, 2)));
        assert_eq!(lf.pixel(1, 0, 5, 7, 1), Some(code(1, 0, 5, 7, 1)));
        assert_eq!(lf.pixel(3, 0, 0, 0, 0), None);
        assert_eq!(lf.pixel(0, 0, 16, 0, 0), None);
        assert_eq!(lf.pixel(0, 0, 0, 17, 0), None);
        assert_eq!(lf.pixel(0, 0, 0, 0, 3), None);
        let v = lf.center_view();
        assert_eq!(lf.grid().center(), (1, 1));
        assert_eq!(v.pixel(4, 9, 0), Some(code(1, 1, 4, 9, 0)));
        assert_eq!(v.row(3).unwrap().len(), 48);
    }

    #[test]
    fn epis_traverse_the_grid() {
        let (data, layout) = coded();
        let lf = LightField::new(&data[..], layout).unwrap();
        let h = lf.epi_horizontal(2, 11).unwrap();
        assert_eq!((h.views(), h.samples()), (4, 16));
        for k in 0..4 {
            for t in 0..16 {
                assert_eq!(h.get(k, t, 1), Some(code(2, k, t, 11, 1)));
            }
        }
        let v = lf.epi_vertical(3, 6).unwrap();
        assert_eq!((v.views(), v.samples()), (3, 17));
        for k in 0..3 {
            for t in 0..17 {
                assert_eq!(v.get(k, t, 2), Some(code(k, 3, 6, t, 2)));
            }
        }
        assert_eq!(v.get(3, 0, 0), None);
        assert!(lf.epi_horizontal(3, 0).is_err());
        assert!(lf.epi_vertical(0, 16).is_err());
    }

    #[test]
    fn views_over_caller_memory_are_checked() {
        let (data, layout) = coded();
        let lf = LightField::new(&data[..], layout).unwrap();
        let start = layout.grid.index(1, 1) * layout.view_stride + 2 * 50 + 3 * 3;
        let v = View::new(&data[start..], 5, 4, 3, 50).unwrap();
        assert_eq!(v.pixel(1, 2, 2), lf.pixel(1, 1, 4, 4, 2));
        assert_eq!(v.pixel(5, 0, 0), None);
        assert!(matches!(
            View::new(&data[..10], 5, 4, 3, 50),
            Err(Error::BufferTooSmall { needed: 165, .. })
        ));
        assert!(matches!(
            View::new(&data[..], 5, 4, 3, 14),
            Err(Error::Stride { needed: 15, .. })
        ));
        assert!(View::new(&data[..], 0, 4, 3, 50).is_err());
        assert!(View::new(&data[..], 5, 4, 2, 50).is_err());
    }

    #[test]
    fn even_grids_have_an_integer_centre() {
        assert_eq!(Grid::new(8, 4).center(), (3, 1));
        assert_eq!(Grid::new(9, 9).center(), (4, 4));
    }

    #[test]
    fn validation_rejects_bad_layouts() {
        let ok = Layout::packed(Grid::new(9, 9), 32, 32, 3);
        assert_eq!(ok.validate(), Ok(81 * 32 * 32 * 3));
        let mut l = ok;
        l.grid = Grid::new(1, 2);
        assert_eq!(l.validate(), Err(Error::GridSize { rows: 1, cols: 2 }));
        for bad in [(1, 1), (2, 1), (2, 9), (1, 18), (18, 1), (0, 9)] {
            l.grid = Grid::new(bad.0, bad.1);
            assert!(
                matches!(l.validate(), Err(Error::GridSize { .. })),
                "{bad:?}"
            );
        }
        // A linear array: one row or one column of 3 to 17 cameras.
        for rail in [(1, 3), (1, 9), (1, 17), (9, 1), (3, 1)] {
            l.grid = Grid::new(rail.0, rail.1);
            assert_eq!(l.validate(), Ok(rail.0 * rail.1 * 32 * 32 * 3), "{rail:?}");
            assert!(l.grid.is_linear());
        }
        assert!(!Grid::new(9, 9).is_linear());
        l.grid = Grid::new(18, 9);
        assert!(matches!(l.validate(), Err(Error::GridSize { .. })));
        let mut l = ok;
        l.width = 15;
        assert!(matches!(l.validate(), Err(Error::ViewTooSmall { .. })));
        let mut l = ok;
        l.channels = 2;
        assert!(matches!(l.validate(), Err(Error::Channels { channels: 2 })));
        let mut l = ok;
        l.row_stride = 95;
        assert!(matches!(
            l.validate(),
            Err(Error::Stride { needed: 96, .. })
        ));
        let mut l = ok;
        l.view_stride -= 1;
        assert!(matches!(l.validate(), Err(Error::Stride { .. })));
        let huge = Layout::packed(Grid::new(17, 17), usize::MAX / 2, 1 << 20, 4);
        assert!(matches!(huge.validate(), Err(Error::SizeOverflow { .. })));
        let zero = Layout::packed(Grid::new(9, 9), 0, 0, 3);
        assert!(matches!(zero.validate(), Err(Error::ViewTooSmall { .. })));
    }

    #[test]
    fn short_buffers_are_rejected() {
        let layout = Layout::packed(Grid::new(3, 3), 16, 16, 1);
        let data = [0u8; 9 * 256 - 1];
        assert_eq!(
            LightField::new(&data[..], layout).err(),
            Some(Error::BufferTooSmall {
                what: "the light-field buffer",
                needed: 9 * 256,
                got: 9 * 256 - 1
            })
        );
    }
}
