//! The realistic scenes: rooms whose walls, floors and ceilings are planes of the whole
//! frame, with objects standing on the floor.
//!
//! The camera is inside the room, a convex box, so the nearest of its planes (largest
//! disparity) is the one a ray leaves the room through: every room plane covers the
//! whole frame and the renderer's nearest-surface rule draws their junctions. An object
//! standing on the floor takes the floor's disparity at its contact row, so the floor
//! hides it below that row and it meets the floor without a gap.

use super::super::light::Lighting;
use super::super::surface::{Shape, Support, Surface};
use super::{region, Builder, CONTRAST, LOW_CONTRAST, MAX_VIEW_SLOPE};

/// Texture contrast of a faintly textured wall or a pale statue: about 1 gray level
/// where it is dimly lit.
const FAINT: f64 = 0.025;
/// Texture contrast of ordinary room surfaces (plaster, wood, fabric): a third of the
/// basic scenes' strong texture.
const MATTE: f64 = 0.08;

/// How a surface looks: its texture's contrast and its albedo (the texture's scale).
#[derive(Clone, Copy, Debug)]
struct Material {
    contrast: f64,
    albedo: f64,
}

/// A plane receding from the camera: disparity `d0` at row `y0`, growing by `slope`
/// per row below it.
#[derive(Clone, Copy, Debug)]
struct Floor {
    y0: f64,
    d0: f64,
    slope: f64,
}

impl Floor {
    fn at(&self, y: f64) -> f64 {
        self.d0 + self.slope * (y - self.y0)
    }
}

impl Builder {
    /// Disparity clamped into the scene's range.
    fn clamp(&self, d: f64) -> f64 {
        d.clamp(self.d_min, self.d_max)
    }

    /// A fronto-parallel back wall over the whole frame at the smallest disparity.
    fn back_wall(&mut self, contrast: f64, albedo: f64) {
        let shape = Shape::Plane {
            a: self.d_min,
            b: 0.0,
            c: 0.0,
            support: Support::All,
        };
        self.push_material(shape, contrast, albedo, region::WALL);
    }

    /// The largest gradient a plane may have along one view axis of reach `max`.
    fn steepest(&self, max: f64) -> f64 {
        MAX_VIEW_SLOPE / max.max(1.0)
    }

    /// A floor meeting the back wall at row `fraction · height` and reaching disparity
    /// `d_bottom` at the bottom row (less where the per-view slope limit forbids).
    fn floor(&mut self, fraction: f64, d_bottom: f64, contrast: f64, albedo: f64) -> Floor {
        let y0 = fraction * (self.height - 1.0);
        let rows = (self.height - 1.0 - y0).max(1.0);
        let slope = ((d_bottom - self.d_min) / rows).min(self.steepest(self.max_v));
        let floor = Floor {
            y0,
            d0: self.d_min,
            slope,
        };
        let shape = Shape::Plane {
            a: self.d_min - slope * y0,
            b: 0.0,
            c: slope,
            support: Support::All,
        };
        self.push_material(shape, contrast, albedo, region::FLOOR);
        floor
    }

    /// A ceiling meeting the back wall at row `fraction · height`, reaching `d_top` at
    /// the top row.
    fn ceiling(&mut self, fraction: f64, d_top: f64, contrast: f64, albedo: f64) {
        let y0 = fraction * (self.height - 1.0);
        let slope = ((d_top - self.d_min) / y0.max(1.0)).min(self.steepest(self.max_v));
        let shape = Shape::Plane {
            a: self.d_min + slope * y0,
            b: 0.0,
            c: -slope,
            support: Support::All,
        };
        self.push_material(shape, contrast, albedo, region::WALL);
    }

    /// A side wall meeting the back wall at column `fraction · width`, reaching `d_edge`
    /// at the image edge it faces (left when `left`).
    fn side_wall(&mut self, fraction: f64, left: bool, d_edge: f64, contrast: f64, albedo: f64) {
        let x0 = fraction * (self.width - 1.0);
        let span = if left { x0 } else { self.width - 1.0 - x0 };
        let slope = ((d_edge - self.d_min) / span.max(1.0)).min(self.steepest(self.max_u));
        let b = if left { -slope } else { slope };
        let shape = Shape::Plane {
            a: self.d_min - b * x0,
            b,
            c: 0.0,
            support: Support::All,
        };
        self.push_material(shape, contrast, albedo, region::WALL);
    }

    /// An upright fronto-parallel rectangle standing on `floor`: bottom centre at
    /// fractions `(fx, fy)` of the frame, half extents as fractions of the scene size.
    fn standing(
        &mut self,
        floor: Floor,
        (fx, fy): (f64, f64),
        (half_width, half_height): (f64, f64),
        material: Material,
        region: u8,
    ) {
        let bottom = fy * (self.height - 1.0);
        let (hw, hh) = (half_width * self.size, half_height * self.size);
        let shape = Shape::Plane {
            a: self.clamp(floor.at(bottom)),
            b: 0.0,
            c: 0.0,
            support: Support::Rect {
                cx: fx * (self.width - 1.0),
                cy: bottom - hh,
                cos: 1.0,
                sin: 0.0,
                half_length: hw,
                half_width: hh,
            },
        };
        self.push_material(shape, material.contrast, material.albedo, region);
    }

    /// A vertical pole `width` pixels wide standing on `floor` at column fraction `fx`,
    /// from row fraction `top` down to `bottom`.
    fn pole(&mut self, floor: Floor, fx: f64, top: f64, bottom: f64, width: f64) {
        let (y0, y1) = (top * (self.height - 1.0), bottom * (self.height - 1.0));
        let shape = Shape::Plane {
            a: self.clamp(floor.at(y1)),
            b: 0.0,
            c: 0.0,
            support: Support::Rect {
                cx: fx * (self.width - 1.0),
                cy: (y0 + y1) / 2.0,
                cos: 0.0,
                sin: 1.0,
                half_length: (y1 - y0) / 2.0,
                half_width: width / 2.0,
            },
        };
        self.push_material(shape, CONTRAST, 0.7, region::THIN);
    }

    /// A wire `width` pixels wide through fraction point `(fx, fy)` at angle `angle`,
    /// `half_length` (fraction of the size) either way, at disparity `d`.
    fn wire(&mut self, (fx, fy): (f64, f64), angle: f64, half_length: f64, width: f64, d: f64) {
        let shape = Shape::Plane {
            a: self.clamp(d),
            b: 0.0,
            c: 0.0,
            support: Support::Rect {
                cx: fx * (self.width - 1.0),
                cy: fy * (self.height - 1.0),
                cos: libm::cos(angle),
                sin: libm::sin(angle),
                half_length: half_length * self.size,
                half_width: width / 2.0,
            },
        };
        self.push_material(shape, CONTRAST, 0.8, region::THIN);
    }

    /// A round object (a cap bulging `height` towards the camera) of radius `radius`
    /// (fraction of the size) resting on `floor` at bottom fractions `(fx, fy)`.
    /// Returns its centre, radius, base and height.
    fn ball(
        &mut self,
        floor: Floor,
        (fx, fy): (f64, f64),
        radius: f64,
        height: f64,
        material: Material,
    ) -> (f64, f64, f64, f64, f64) {
        let bottom = fy * (self.height - 1.0);
        let r = radius * self.size;
        let base = self.clamp(floor.at(bottom));
        let height = height.min(self.d_max - base).max(1e-3);
        let (cx, cy) = (fx * (self.width - 1.0), bottom - r);
        let shape = Shape::Cap {
            cx,
            cy,
            radius: r,
            base,
            height,
        };
        self.push_material(shape, material.contrast, material.albedo, region::OBJECT);
        (cx, cy, r, base, height)
    }

    /// `count` shallow bumps (radius `size·[lo, hi]`, protruding up to `max_height`)
    /// carved into the surface added last, of disparity `surface(x, y)`, centred at
    /// random inside the ellipse of centre `(cx, cy)` and half axes `(ax, ay)`. They
    /// share that surface's texture, so only their relief tells them apart.
    fn bumps(
        &mut self,
        count: usize,
        (cx, cy): (f64, f64),
        (ax, ay): (f64, f64),
        (lo, hi): (f64, f64),
        max_height: f64,
        surface: impl Fn(f64, f64) -> f64,
    ) {
        let Some(carrier) = self
            .scene
            .len
            .checked_sub(1)
            .and_then(|k| self.scene.surfaces.get(k))
        else {
            return;
        };
        let texture = carrier.texture;
        for _ in 0..count {
            let angle = self.rng.range(0.0, core::f64::consts::TAU);
            let reach = crate::float::sqrt(self.rng.unit());
            let (x, y) = (
                cx + ax * reach * libm::cos(angle),
                cy + ay * reach * libm::sin(angle),
            );
            let radius = self.size * self.rng.range(lo, hi);
            let height = self.rng.range(0.3, 1.0) * max_height;
            // The cap's base lies below the surface, so only its top protrudes.
            let base = surface(x, y) - 0.4 * height;
            let height = height.min(self.d_max - base).max(1e-3);
            let shape = Shape::Cap {
                cx: x,
                cy: y,
                radius,
                base,
                height,
            };
            if let (Some(slot), Some(flags)) = (
                self.scene.surfaces.get_mut(self.scene.len),
                self.scene.regions.get_mut(self.scene.len),
            ) {
                *slot = Surface { shape, texture };
                *flags = region::RELIEF;
                self.scene.len += 1;
            }
        }
    }

    fn light(&mut self, (fx, fy): (f64, f64), radius: f64, ambient: f64) {
        self.scene.lighting = Some(Lighting {
            x: fx * (self.width - 1.0),
            y: fy * (self.height - 1.0),
            radius: radius * self.size,
            ambient,
        });
    }

    pub(super) fn hall(&mut self) {
        self.back_wall(FAINT, 0.45);
        let floor = self.floor(0.48, self.d_max, MATTE, 0.8);
        let range = self.d_max - self.d_min;
        let statue = self.ball(
            floor,
            (0.6, 0.86),
            0.17,
            range * 0.2,
            Material {
                contrast: FAINT,
                albedo: 0.95,
            },
        );
        let (cx, cy, r, base, height) = statue;
        self.bumps(
            12,
            (cx, cy),
            (0.7 * r, 0.7 * r),
            (0.01, 0.03),
            range * 0.05,
            move |x, y| cap_at(x, y, cx, cy, r, base, height),
        );
        self.standing(
            floor,
            (0.2, 0.74),
            (0.09, 0.12),
            Material {
                contrast: CONTRAST,
                albedo: 0.6,
            },
            region::OBJECT,
        );
        self.pole(floor, 0.86, 0.08, 0.95, 2.0);
        let d = self.level(0.3);
        self.wire((0.25, 0.28), 0.05, 0.2, 1.0, d);
        self.light((0.55, 0.7), 0.35, 0.2);
    }

    pub(super) fn corridor(&mut self) {
        self.back_wall(MATTE, 0.6);
        let floor = self.floor(0.5, self.d_max, MATTE, 0.75);
        self.ceiling(0.3, self.level(0.6), MATTE, 0.7);
        self.side_wall(0.38, true, self.level(0.75), MATTE, 0.65);
        self.side_wall(0.62, false, self.level(0.75), MATTE, 0.65);
        self.standing(
            floor,
            (0.3, 0.82),
            (0.07, 0.09),
            Material {
                contrast: CONTRAST,
                albedo: 0.6,
            },
            region::OBJECT,
        );
        self.standing(
            floor,
            (0.56, 0.62),
            (0.04, 0.05),
            Material {
                contrast: CONTRAST,
                albedo: 0.6,
            },
            region::OBJECT,
        );
        let range = self.d_max - self.d_min;
        self.ball(
            floor,
            (0.45, 0.72),
            0.05,
            range * 0.05,
            Material {
                contrast: CONTRAST,
                albedo: 0.8,
            },
        );
        self.pole(floor, 0.7, 0.35, 0.92, 3.0);
        self.light((0.5, 0.45), 0.3, 0.3);
    }

    pub(super) fn tabletop(&mut self) {
        self.back_wall(MATTE, 0.55);
        let floor = self.floor(0.4, self.level(0.95), MATTE, 0.8);
        self.standing(
            floor,
            (0.2, 0.55),
            (0.08, 0.1),
            Material {
                contrast: CONTRAST,
                albedo: 0.7,
            },
            region::OBJECT,
        );
        self.standing(
            floor,
            (0.5, 0.62),
            (0.1, 0.08),
            Material {
                contrast: LOW_CONTRAST,
                albedo: 0.8,
            },
            region::OBJECT | region::LOW_TEXTURE,
        );
        self.standing(
            floor,
            (0.8, 0.8),
            (0.07, 0.14),
            Material {
                contrast: CONTRAST,
                albedo: 0.6,
            },
            region::OBJECT,
        );
        let range = self.d_max - self.d_min;
        self.ball(
            floor,
            (0.35, 0.85),
            0.07,
            range * 0.08,
            Material {
                contrast: CONTRAST,
                albedo: 0.8,
            },
        );
        self.ball(
            floor,
            (0.65, 0.93),
            0.05,
            range * 0.06,
            Material {
                contrast: CONTRAST,
                albedo: 0.8,
            },
        );
        // Pencils lying on the table, a little above it.
        for (centre, angle, width) in [((0.3, 0.7), 0.3, 2.0), ((0.6, 0.78), -0.5, 3.0)] {
            let (cx, cy) = (
                centre.0 * (self.width - 1.0),
                centre.1 * (self.height - 1.0),
            );
            let lift = 0.02 * range;
            let shape = Shape::Plane {
                a: floor.at(0.0) + lift,
                b: 0.0,
                c: floor.slope,
                support: Support::Rect {
                    cx,
                    cy,
                    cos: libm::cos(angle),
                    sin: libm::sin(angle),
                    half_length: 0.12 * self.size,
                    half_width: width / 2.0,
                },
            };
            self.push_material(shape, CONTRAST, 0.8, region::THIN);
        }
        self.pole(floor, 0.42, 0.2, 0.7, 1.0);
        self.light((0.25, 0.35), 0.45, 0.35);
    }

    pub(super) fn dusk(&mut self) {
        self.back_wall(MATTE, 0.5);
        // A poster on the wall: hardly any texture, a hair in front of it.
        let shape = Shape::Plane {
            a: self.d_min + 0.002 * (self.d_max - self.d_min),
            b: 0.0,
            c: 0.0,
            support: Support::Rect {
                cx: 0.62 * (self.width - 1.0),
                cy: 0.25 * (self.height - 1.0),
                cos: 1.0,
                sin: 0.0,
                half_length: 0.15 * self.size,
                half_width: 0.1 * self.size,
            },
        };
        self.push_material(shape, LOW_CONTRAST, 0.6, region::WALL | region::LOW_TEXTURE);
        let floor = self.floor(0.5, self.level(0.9), MATTE, 0.7);
        self.side_wall(0.25, true, self.level(0.85), MATTE, 0.6);
        self.standing(
            floor,
            (0.5, 0.8),
            (0.1, 0.12),
            Material {
                contrast: CONTRAST,
                albedo: 0.6,
            },
            region::OBJECT,
        );
        let range = self.d_max - self.d_min;
        self.ball(
            floor,
            (0.78, 0.9),
            0.1,
            range * 0.1,
            Material {
                contrast: CONTRAST,
                albedo: 0.7,
            },
        );
        self.light((1.15, 0.15), 0.5, 0.1);
    }

    pub(super) fn relief(&mut self) {
        self.back_wall(MATTE, 0.6);
        self.floor(0.7, self.level(0.8), MATTE, 0.75);
        // A panel turned about the vertical axis, carved with shallow bumps.
        let range = self.d_max - self.d_min;
        let (cx, cy) = (0.45 * (self.width - 1.0), 0.4 * (self.height - 1.0));
        let (hx, hy) = (0.3 * self.size, 0.22 * self.size);
        let dc = self.level(0.45);
        let b = (0.25 * range / hx).min(self.steepest(self.max_u));
        let shape = Shape::Plane {
            a: dc - b * cx,
            b,
            c: 0.0,
            support: Support::Rect {
                cx,
                cy,
                cos: 1.0,
                sin: 0.0,
                half_length: hx,
                half_width: hy,
            },
        };
        self.push_material(shape, 0.12, 0.7, region::OBJECT);
        self.bumps(
            18,
            (cx, cy),
            (0.85 * hx, 0.85 * hy),
            (0.012, 0.04),
            range * 0.08,
            move |x, _| dc + b * (x - cx),
        );
        for (k, angle) in [0.2, -0.35, 1.3].into_iter().enumerate() {
            let d = self.level(0.85 + 0.05 * k as f64);
            let centre = (0.3 + 0.2 * k as f64, 0.3 + 0.15 * k as f64);
            self.wire(centre, angle, 0.25, 1.0, d);
        }
        self.light((0.3, 0.2), 0.5, 0.3);
    }
}

/// Disparity of the cap `(cx, cy, r, base, height)` at `(x, y)` (its base outside).
fn cap_at(x: f64, y: f64, cx: f64, cy: f64, r: f64, base: f64, height: f64) -> f64 {
    let rho2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (r * r);
    base + height * crate::float::sqrt((1.0 - rho2).max(0.0))
}
