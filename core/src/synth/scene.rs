//! Scene builders: the seeded arrangement of surfaces for each [`SceneKind`].
//!
//! Every surface keeps its disparity inside `[disparity_min, disparity_max]` over the
//! centre view (planes are fitted at their corners, caps peak at most at the maximum), and
//! every plane keeps `|b|·max|u| + |c|·max|v| ≤ 0.5`, so each ray meets it exactly once.

mod realistic;

use super::light::Lighting;
use super::rng::Rng;
use super::surface::{Shape, Support, Surface};
use super::texture::Texture;
use super::{SceneKind, SynthSpec};

/// Most surfaces a scene holds (background included).
pub(crate) const MAX_SURFACES: usize = 32;

/// What a surface is, as flags (see `render_regions`): for scoring an estimate by
/// region.
pub mod region {
    /// A floor or table top: a plane receding from the camera.
    pub const FLOOR: u8 = 1;
    /// A wall or ceiling.
    pub const WALL: u8 = 2;
    /// An object standing in the scene (box, ball, statue, panel).
    pub const OBJECT: u8 = 4;
    /// A bar or wire 1–3 px wide.
    pub const THIN: u8 = 8;
    /// A shallow bump of fine relief.
    pub const RELIEF: u8 = 16;
    /// A surface with very weak texture (≈ 2 gray levels).
    pub const LOW_TEXTURE: u8 = 32;
    /// Lit radiance below a fifth of full scale at that point.
    pub const DIM: u8 = 64;
}

/// Texture contrast (standard deviation of linear radiance) of ordinary surfaces.
const CONTRAST: f64 = 0.2;
/// Contrast of "low-texture" surfaces: about 2 levels of 255.
const LOW_CONTRAST: f64 = 0.008;
/// Largest `|b|·max|u| + |c|·max|v|` of a plane.
const MAX_VIEW_SLOPE: f64 = 0.5;

/// The surfaces of one scene; the first is the background, which covers everything.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Scene {
    surfaces: [Surface; MAX_SURFACES],
    /// The [`region`] flags of each surface.
    regions: [u8; MAX_SURFACES],
    len: usize,
    /// Uneven illumination (`None`: every surface shows its own radiance).
    pub(crate) lighting: Option<Lighting>,
}

impl Scene {
    pub(crate) fn surfaces(&self) -> &[Surface] {
        self.surfaces.get(..self.len).unwrap_or(&[])
    }

    /// The [`region`] flags of surface `k`.
    pub(crate) fn region(&self, k: usize) -> u8 {
        self.regions.get(k).copied().unwrap_or(0)
    }

    /// A scene of the given surfaces (at most [`MAX_SURFACES`]; the first must cover
    /// everything).
    #[cfg(test)]
    pub(crate) fn from_surfaces(list: &[Surface]) -> Scene {
        let mut scene = Scene {
            surfaces: [Texture::FLAT; MAX_SURFACES].map(|texture| Surface {
                shape: Shape::Plane {
                    a: 0.0,
                    b: 0.0,
                    c: 0.0,
                    support: Support::All,
                },
                texture,
            }),
            regions: [0; MAX_SURFACES],
            len: 0,
            lighting: None,
        };
        for (slot, s) in scene.surfaces.iter_mut().zip(list) {
            *slot = *s;
            scene.len += 1;
        }
        scene
    }

    /// Builds the scene of a validated spec (same spec → same scene).
    pub(crate) fn build(spec: &SynthSpec) -> Scene {
        let mut b = Builder::new(spec);
        match spec.scene {
            SceneKind::Planes => b.planes(),
            SceneKind::Slanted => b.slanted(),
            SceneKind::Spheres => b.spheres(),
            SceneKind::Occlusion => b.occlusion(),
            SceneKind::Thin => b.thin(),
            SceneKind::LowTexture => b.low_texture(),
            SceneKind::Mixed => b.mixed(),
            SceneKind::Hall => b.hall(),
            SceneKind::Corridor => b.corridor(),
            SceneKind::Tabletop => b.tabletop(),
            SceneKind::Dusk => b.dusk(),
            SceneKind::Relief => b.relief(),
        }
        b.scene
    }
}

struct Builder {
    scene: Scene,
    rng: Rng,
    gray: bool,
    width: f64,
    height: f64,
    /// min(width, height): scene features scale with it.
    size: f64,
    d_min: f64,
    d_max: f64,
    max_u: f64,
    max_v: f64,
}

impl Builder {
    fn new(spec: &SynthSpec) -> Self {
        let (r0, c0) = spec.grid.center();
        let max_u = c0.max(spec.grid.cols.saturating_sub(1 + c0)) as f64;
        let max_v = r0.max(spec.grid.rows.saturating_sub(1 + r0)) as f64;
        let (width, height) = (spec.width as f64, spec.height as f64);
        Builder {
            scene: Scene {
                surfaces: [Surface {
                    shape: Shape::Plane {
                        a: 0.0,
                        b: 0.0,
                        c: 0.0,
                        support: Support::All,
                    },
                    texture: Texture::FLAT,
                }; MAX_SURFACES],
                regions: [0; MAX_SURFACES],
                len: 0,
                lighting: None,
            },
            rng: Rng::stream(spec.seed, 0x5CE4E, spec.scene as u64),
            gray: spec.channels == 1,
            width,
            height,
            size: width.min(height),
            d_min: spec.disparity_min as f64,
            d_max: spec.disparity_max as f64,
            max_u,
            max_v,
        }
    }

    fn push(&mut self, shape: Shape, contrast: f64) {
        let texture = Texture::random(&mut self.rng, contrast, self.gray);
        if let Some(slot) = self.scene.surfaces.get_mut(self.scene.len) {
            *slot = Surface { shape, texture };
            self.scene.len += 1;
        }
    }

    /// Adds a surface of the given texture contrast, albedo (a factor on its radiance)
    /// and [`region`] flags.
    fn push_material(&mut self, shape: Shape, contrast: f64, albedo: f64, region: u8) {
        let texture = Texture::random(&mut self.rng, contrast, self.gray).scaled(albedo);
        if let (Some(slot), Some(flags)) = (
            self.scene.surfaces.get_mut(self.scene.len),
            self.scene.regions.get_mut(self.scene.len),
        ) {
            *slot = Surface { shape, texture };
            *flags = region;
            self.scene.len += 1;
        }
    }

    /// Disparity at fraction `t` of the range.
    fn level(&self, t: f64) -> f64 {
        self.d_min + (self.d_max - self.d_min) * t
    }

    /// A random gradient `(b, c)` for a plane of centre disparity `dc` whose support extends
    /// `±ext_x, ±ext_y` from its centre: as steep as allowed (times `steepness` ∈ (0, 1])
    /// while staying inside the disparity range and the per-view slope limit.
    fn gradient(&mut self, dc: f64, ext_x: f64, ext_y: f64, steepness: f64) -> (f64, f64) {
        let angle = self.rng.range(0.0, core::f64::consts::TAU);
        let (dx, dy) = (libm::cos(angle), libm::sin(angle));
        let headroom = (dc - self.d_min).min(self.d_max - dc).max(0.0);
        // Largest s with s(|dx|ext_x + |dy|ext_y) ≤ headroom and s(|dx|U + |dy|V) ≤ limit.
        let reach = libm::fabs(dx) * ext_x + libm::fabs(dy) * ext_y;
        let view_reach = libm::fabs(dx) * self.max_u + libm::fabs(dy) * self.max_v;
        let s = (headroom / reach.max(1e-9)).min(MAX_VIEW_SLOPE / view_reach.max(1e-9));
        (s * steepness * dx, s * steepness * dy)
    }

    fn background_fronto(&mut self, d: f64, contrast: f64) {
        self.push(
            Shape::Plane {
                a: d,
                b: 0.0,
                c: 0.0,
                support: Support::All,
            },
            contrast,
        );
    }

    /// A background plane slanted within the range, disparity `dc` at the image centre.
    fn background_slanted(&mut self, dc: f64, contrast: f64) {
        let (hx, hy) = ((self.width - 1.0) / 2.0, (self.height - 1.0) / 2.0);
        let (b, c) = self.gradient(dc, hx, hy, 1.0);
        self.push(
            Shape::Plane {
                a: dc - b * hx - c * hy,
                b,
                c,
                support: Support::All,
            },
            contrast,
        );
    }

    /// A random position inside the central `[margin, 1 − margin]` part of the image.
    fn position(&mut self, margin: f64) -> (f64, f64) {
        (
            self.rng.range(margin, 1.0 - margin) * (self.width - 1.0),
            self.rng.range(margin, 1.0 - margin) * (self.height - 1.0),
        )
    }

    /// A rectangle of `outline`: centre disparity `dc`, slant `steepness` (0 = fronto).
    fn rect(&mut self, outline: Outline, dc: f64, steepness: f64, contrast: f64) {
        let Outline {
            centre: (cx, cy),
            angle,
            half_length,
            half_width,
        } = outline;
        let (cos, sin) = (libm::cos(angle), libm::sin(angle));
        let ext_x = libm::fabs(cos) * half_length + libm::fabs(sin) * half_width;
        let ext_y = libm::fabs(sin) * half_length + libm::fabs(cos) * half_width;
        let (b, c) = if steepness > 0.0 {
            self.gradient(dc, ext_x, ext_y, steepness)
        } else {
            (0.0, 0.0)
        };
        self.push(
            Shape::Plane {
                a: dc - b * cx - c * cy,
                b,
                c,
                support: Support::Rect {
                    cx,
                    cy,
                    cos,
                    sin,
                    half_length,
                    half_width,
                },
            },
            contrast,
        );
    }

    /// A random rectangle of half extents `size·[lo, hi]`.
    fn random_rect(&mut self, lo: f64, hi: f64, dc: f64, steepness: f64, contrast: f64) {
        let centre = self.position(0.15);
        let angle = self.rng.symmetric(0.5);
        let half_length = self.size * self.rng.range(lo, hi);
        let half_width = self.size * self.rng.range(lo, hi);
        self.rect(
            Outline {
                centre,
                angle,
                half_length,
                half_width,
            },
            dc,
            steepness,
            contrast,
        );
    }

    fn cap(&mut self, (cx, cy): (f64, f64), radius: f64, base: f64, height: f64) {
        self.push(
            Shape::Cap {
                cx,
                cy,
                radius,
                base,
                height: height.max(1e-3),
            },
            CONTRAST,
        );
    }

    /// A bar `width` pixels wide (1…3), at disparity `d`.
    fn bar(&mut self, width: f64, angle: f64, d: f64, steepness: f64) {
        let centre = self.position(0.2);
        let half_length = self.size * self.rng.range(0.15, 0.4);
        self.rect(
            Outline {
                centre,
                angle,
                half_length,
                half_width: width / 2.0,
            },
            d,
            steepness,
            CONTRAST,
        );
    }

    fn planes(&mut self) {
        self.background_fronto(self.d_min, CONTRAST);
        let n = 5;
        for k in 0..n {
            let d = self.level((k + 1) as f64 / n as f64);
            self.random_rect(0.08, 0.22, d, 0.0, CONTRAST);
        }
    }

    fn slanted(&mut self) {
        self.background_slanted(self.level(0.2), CONTRAST);
        for t in [0.45, 0.65, 0.85] {
            let d = self.level(t);
            self.random_rect(0.1, 0.25, d, 1.0, CONTRAST);
        }
    }

    fn spheres(&mut self) {
        self.background_fronto(self.d_min, CONTRAST);
        let n = 4;
        for k in 0..n {
            let centre = self.position(0.2);
            let radius = self.size * self.rng.range(0.1, 0.22);
            let t = self.rng.range(0.1, 0.5);
            let base = self.level(t);
            let height = if k == n - 1 {
                self.d_max - base
            } else {
                (self.d_max - base) * self.rng.range(0.3, 1.0)
            };
            self.cap(centre, radius, base, height);
        }
    }

    fn occlusion(&mut self) {
        self.background_fronto(self.d_min, CONTRAST);
        // Overlapping, shrinking layers near the centre: many occlusion edges at
        // different orientations, each a disparity jump of a sixth of the range.
        let n = 6;
        let (mut cx, mut cy) = ((self.width - 1.0) / 2.0, (self.height - 1.0) / 2.0);
        for k in 0..n {
            let d = self.level((k + 1) as f64 / (n + 1) as f64);
            let scale = 0.3 - 0.035 * k as f64;
            cx += self.rng.symmetric(0.08) * self.width;
            cy += self.rng.symmetric(0.08) * self.height;
            let angle = self.rng.symmetric(0.8);
            let half_length = self.size * scale * self.rng.range(0.7, 1.0);
            let half_width = self.size * scale * self.rng.range(0.4, 0.8);
            self.rect(
                Outline {
                    centre: (cx, cy),
                    angle,
                    half_length,
                    half_width,
                },
                d,
                0.0,
                CONTRAST,
            );
        }
        let centre = self.position(0.3);
        let base = self.level(0.85);
        self.cap(centre, self.size * 0.1, base, self.d_max - base);
    }

    fn thin(&mut self) {
        self.background_fronto(self.d_min, CONTRAST);
        let (centre, angle) = (self.position(0.35), self.rng.symmetric(0.3));
        let mid = self.level(0.35);
        self.rect(
            Outline {
                centre,
                angle,
                half_length: self.size * 0.3,
                half_width: self.size * 0.2,
            },
            mid,
            0.0,
            CONTRAST,
        );
        let angles = [0.0, core::f64::consts::FRAC_PI_2, 0.4, -0.9, 1.2, 2.5];
        for (k, angle) in angles.into_iter().enumerate() {
            let width = [1.0, 2.0, 3.0][k % 3];
            let d = self.level(0.55 + 0.45 * k as f64 / (angles.len() - 1) as f64);
            let steepness = if k == 3 { 1.0 } else { 0.0 };
            self.bar(width, angle, d, steepness);
        }
    }

    fn low_texture(&mut self) {
        self.background_fronto(self.d_min, LOW_CONTRAST);
        for t in [0.3, 0.6] {
            let d = self.level(t);
            self.random_rect(0.1, 0.22, d, 0.0, LOW_CONTRAST);
        }
        let d = self.level(0.75);
        self.random_rect(0.1, 0.2, d, 1.0, LOW_CONTRAST);
        self.random_rect(0.06, 0.12, self.d_max, 0.0, CONTRAST);
    }

    fn mixed(&mut self) {
        self.background_slanted(self.level(0.15), CONTRAST);
        let (d1, d2) = (self.level(0.35), self.level(0.5));
        self.random_rect(0.08, 0.18, d1, 0.0, CONTRAST);
        self.random_rect(0.08, 0.18, d2, 0.0, LOW_CONTRAST);
        let d3 = self.level(0.6);
        self.random_rect(0.08, 0.18, d3, 1.0, CONTRAST);
        let centre = self.position(0.25);
        let base = self.level(0.4);
        let radius = self.size * 0.14;
        self.cap(centre, radius, base, (self.d_max - base) * 0.8);
        let angle = self.rng.symmetric(1.5);
        let d = self.level(0.9);
        self.bar(1.0, angle, d, 0.0);
        let angle = self.rng.symmetric(1.5);
        self.bar(2.0, angle, self.d_max, 0.0);
    }
}

/// A rectangle's outline: its centre (pixels), orientation (radians) and half extents
/// (pixels).
#[derive(Clone, Copy)]
struct Outline {
    centre: (f64, f64),
    angle: f64,
    half_length: f64,
    half_width: f64,
}
