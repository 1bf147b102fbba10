//! Surfaces of a synthetic scene, described in centre-view pixel coordinates by their
//! disparity `d(x, y)`, and exact ray hits from any view.
//!
//! A ray through pixel `(x', y')` of the view at offset `(u, v) = (c − c0, r − r0)` meets
//! the surface point `(x, y) = (x' + d·u, y' + d·v)` with `d = d(x, y)` (the HCI sign
//! convention, read backwards). Planes and spherical caps are solved in closed form.

use super::texture::Texture;

/// Where on its disparity function a surface exists (centre-view coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Support {
    /// Everywhere (the background).
    All,
    /// An oriented rectangle: centre, unit axis `(cos, sin)`, half extents along the axis
    /// and across it.
    Rect {
        cx: f64,
        cy: f64,
        cos: f64,
        sin: f64,
        half_length: f64,
        half_width: f64,
    },
}

impl Support {
    fn contains(&self, x: f64, y: f64) -> bool {
        match *self {
            Support::All => true,
            Support::Rect {
                cx,
                cy,
                cos,
                sin,
                half_length,
                half_width,
            } => {
                let (dx, dy) = (x - cx, y - cy);
                libm::fabs(dx * cos + dy * sin) <= half_length
                    && libm::fabs(dy * cos - dx * sin) <= half_width
            }
        }
    }

    /// Axis-aligned bounds `[x0, y0, x1, y1]` (infinite for `All`).
    fn bounds(&self) -> [f64; 4] {
        match *self {
            Support::All => [
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::INFINITY,
            ],
            Support::Rect {
                cx,
                cy,
                cos,
                sin,
                half_length,
                half_width,
            } => {
                let ex = libm::fabs(cos) * half_length + libm::fabs(sin) * half_width;
                let ey = libm::fabs(sin) * half_length + libm::fabs(cos) * half_width;
                [cx - ex, cy - ey, cx + ex, cy + ey]
            }
        }
    }
}

/// The disparity function of a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Shape {
    /// `d = a + b·x + c·y` on its support.
    Plane {
        a: f64,
        b: f64,
        c: f64,
        support: Support,
    },
    /// A spherical cap in (x, y, d) space: `d = base + height·sqrt(1 − ρ²/radius²)` for
    /// `ρ = |(x, y) − (cx, cy)| ≤ radius` (an ellipsoid bulging towards the viewer).
    Cap {
        cx: f64,
        cy: f64,
        radius: f64,
        base: f64,
        height: f64,
    },
}

/// A textured surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Surface {
    pub(crate) shape: Shape,
    pub(crate) texture: Texture,
}

/// A surface prepared for one view offset `(u, v)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ViewSurface {
    /// For planes: the disparity as a function of view coordinates,
    /// `d = alpha + beta·x' + gamma·y'`.
    pub(crate) alpha: f64,
    pub(crate) beta: f64,
    pub(crate) gamma: f64,
    /// Bounds `[x0, y0, x1, y1]` in view coordinates outside which no ray hits.
    pub(crate) bounds: [f64; 4],
    /// For planes on a rectangle: the parallelogram of view points whose rays hit it
    /// (the view → surface map of a plane is affine), vertices in order.
    pub(crate) outline: Option<[(f64, f64); 4]>,
}

/// A pixel's footprint in ideal view coordinates: its four corners in order.
pub(crate) type Quad = [(f64, f64); 4];

fn cross(o: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
}

/// Whether every point of `quad` lies in the convex polygon `outline`.
fn outline_contains(outline: &Quad, quad: &Quad) -> bool {
    let orientation = cross(outline[0], outline[1], outline[2]);
    quad.iter()
        .all(|&q| (0..4).all(|e| cross(outline[e], outline[(e + 1) % 4], q) * orientation >= 0.0))
}

/// Whether an edge normal of the parallelogram `outline` separates it from `quad`
/// (a sufficient condition for them to be disjoint).
fn outline_separated(outline: &Quad, quad: &Quad) -> bool {
    (0..2).any(|e| {
        let (a, b) = (outline[e], outline[e + 1]);
        let normal = (a.1 - b.1, b.0 - a.0);
        let project = |p: &(f64, f64)| p.0 * normal.0 + p.1 * normal.1;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in outline {
            lo = lo.min(project(p));
            hi = hi.max(project(p));
        }
        quad.iter().all(|q| project(q) < lo) || quad.iter().all(|q| project(q) > hi)
    })
}

impl Surface {
    /// Disparity and surface point hit by the ray through view point `(x, y)` of the view
    /// at offset `(u, v)`, or `None` when the ray misses.
    #[inline]
    pub(crate) fn hit(
        &self,
        prepared: &ViewSurface,
        x: f64,
        y: f64,
        u: f64,
        v: f64,
    ) -> Option<(f64, f64, f64)> {
        match self.shape {
            Shape::Plane { support, .. } => {
                let d = prepared.alpha + prepared.beta * x + prepared.gamma * y;
                let (sx, sy) = (x + d * u, y + d * v);
                support.contains(sx, sy).then_some((d, sx, sy))
            }
            Shape::Cap {
                cx,
                cy,
                radius,
                base,
                height,
            } => {
                // With e = d − base and m = (x, y) + base·(u, v) − centre:
                // e²/h² + |m + e·(u, v)|²/r² = 1, take the larger root, which must be ≥ 0.
                let (mx, my) = (x + base * u - cx, y + base * v - cy);
                let r2 = radius * radius;
                let k = 1.0 / (height * height) + (u * u + v * v) / r2;
                let half_b = (mx * u + my * v) / r2;
                let c = (mx * mx + my * my) / r2 - 1.0;
                let discriminant = half_b * half_b - k * c;
                if discriminant < 0.0 {
                    return None;
                }
                let e = (-half_b + crate::float::sqrt(discriminant)) / k;
                if e.is_nan() || e < 0.0 {
                    return None;
                }
                let d = base + e;
                Some((d, x + d * u, y + d * v))
            }
        }
    }

    /// Precomputes the view-dependent terms for the view at offset `(u, v)`.
    ///
    /// Planes must satisfy `b·u + c·v < 1` (the scene builder keeps it ≤ 0.5) so each ray
    /// meets the plane once.
    pub(crate) fn prepare(&self, u: f64, v: f64) -> ViewSurface {
        match self.shape {
            Shape::Plane { a, b, c, support } => {
                // d = a + b(x' + d·u) + c(y' + d·v)  ⇒  d = (a + b·x' + c·y') / (1 − b·u − c·v).
                let den = 1.0 - b * u - c * v;
                let (alpha, beta, gamma) = (a / den, b / den, c / den);
                let [x0, y0, x1, y1] = support.bounds();
                let bounds = if matches!(support, Support::All) {
                    support.bounds()
                } else {
                    // Disparity range over the support's bounding box (a plane is extreme
                    // at its corners), then p' = p − d·(u, v).
                    let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)];
                    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                    for (x, y) in corners {
                        let d = a + b * x + c * y;
                        lo = lo.min(d);
                        hi = hi.max(d);
                    }
                    shift_bounds([x0, y0, x1, y1], lo, hi, u, v)
                };
                let outline = match support {
                    Support::All => None,
                    Support::Rect {
                        cx,
                        cy,
                        cos,
                        sin,
                        half_length,
                        half_width,
                    } => {
                        let corner = |sl: f64, sw: f64| {
                            let x = cx + sl * half_length * cos - sw * half_width * sin;
                            let y = cy + sl * half_length * sin + sw * half_width * cos;
                            let d = a + b * x + c * y;
                            (x - d * u, y - d * v)
                        };
                        Some([
                            corner(1.0, 1.0),
                            corner(-1.0, 1.0),
                            corner(-1.0, -1.0),
                            corner(1.0, -1.0),
                        ])
                    }
                };
                ViewSurface {
                    alpha,
                    beta,
                    gamma,
                    bounds,
                    outline,
                }
            }
            Shape::Cap {
                cx,
                cy,
                radius,
                base,
                height,
            } => ViewSurface {
                alpha: 0.0,
                beta: 0.0,
                gamma: 0.0,
                bounds: shift_bounds(
                    [cx - radius, cy - radius, cx + radius, cy + radius],
                    base,
                    base + height,
                    u,
                    v,
                ),
                outline: None,
            },
        }
    }

    /// Whether the surface certainly covers the whole footprint `quad`, given the offset
    /// `(u, v)` of the view.
    ///
    /// For caps: the view points whose rays hit the cap are the projection (along the
    /// rays) of the solid half-ellipsoid, a convex set, so four hit corners suffice.
    pub(crate) fn covers(&self, prepared: &ViewSurface, quad: &Quad, u: f64, v: f64) -> bool {
        match (self.shape, prepared.outline) {
            (
                Shape::Plane {
                    support: Support::All,
                    ..
                },
                _,
            ) => true,
            (Shape::Plane { .. }, Some(outline)) => outline_contains(&outline, quad),
            (Shape::Cap { .. }, _) => quad
                .iter()
                .all(|&(x, y)| self.hit(prepared, x, y, u, v).is_some()),
            _ => false,
        }
    }

    /// Whether the surface certainly misses the footprint `quad` (beyond `bounds`).
    ///
    /// For caps: hits lie within `radius` of the segment swept by the disk centre
    /// `c − d·(u, v)` for `d` in `[base, base + height]`.
    pub(crate) fn misses(&self, prepared: &ViewSurface, quad: &Quad, u: f64, v: f64) -> bool {
        match self.shape {
            Shape::Plane { .. } => prepared
                .outline
                .is_some_and(|outline| outline_separated(&outline, quad)),
            Shape::Cap {
                cx,
                cy,
                radius,
                base,
                height,
            } => {
                let (mx, my) = (
                    quad.iter().map(|q| q.0).sum::<f64>() / 4.0,
                    quad.iter().map(|q| q.1).sum::<f64>() / 4.0,
                );
                let reach = quad
                    .iter()
                    .map(|q| (q.0 - mx) * (q.0 - mx) + (q.1 - my) * (q.1 - my))
                    .fold(0.0, f64::max);
                let reach = crate::float::sqrt(reach);
                let (ax, ay) = (cx - base * u, cy - base * v);
                let (sx, sy) = (-height * u, -height * v);
                let length2 = sx * sx + sy * sy;
                let t = if length2 > 0.0 {
                    (((mx - ax) * sx + (my - ay) * sy) / length2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (mx - ax - t * sx, my - ay - t * sy);
                let distance = crate::float::sqrt(ex * ex + ey * ey);
                distance > radius + reach + 1e-9
            }
        }
    }

    /// Bounds of the disparity the surface can show inside the footprint `quad`.
    pub(crate) fn disparity_range(&self, prepared: &ViewSurface, quad: &Quad) -> (f64, f64) {
        match self.shape {
            Shape::Plane { .. } => {
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for &(x, y) in quad {
                    let d = prepared.alpha + prepared.beta * x + prepared.gamma * y;
                    lo = lo.min(d);
                    hi = hi.max(d);
                }
                (lo, hi)
            }
            Shape::Cap { base, height, .. } => (base, base + height),
        }
    }

    /// Whether the surface is a plane (its pixels can be box-filtered in closed form).
    pub(crate) fn is_plane(&self) -> bool {
        matches!(self.shape, Shape::Plane { .. })
    }
}

/// Bounds in view coordinates of centre-view bounds whose disparity lies in `[lo, hi]`.
fn shift_bounds(b: [f64; 4], lo: f64, hi: f64, u: f64, v: f64) -> [f64; 4] {
    const MARGIN: f64 = 1e-6;
    let (ulo, uhi) = (min2(lo * u, hi * u), max2(lo * u, hi * u));
    let (vlo, vhi) = (min2(lo * v, hi * v), max2(lo * v, hi * v));
    [
        b[0] - uhi - MARGIN,
        b[1] - vhi - MARGIN,
        b[2] - ulo + MARGIN,
        b[3] - vlo + MARGIN,
    ]
}

fn min2(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

fn max2(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surface(shape: Shape) -> Surface {
        Surface {
            shape,
            texture: Texture::FLAT,
        }
    }

    #[test]
    fn plane_hits_satisfy_the_disparity_equation() {
        let s = surface(Shape::Plane {
            a: 0.3,
            b: 0.004,
            c: -0.003,
            support: Support::All,
        });
        for (u, v) in [(0.0, 0.0), (3.0, -2.0), (-4.0, 4.0)] {
            let p = s.prepare(u, v);
            let (d, x, y) = s.hit(&p, 17.25, 40.5, u, v).unwrap();
            assert!((x - (17.25 + d * u)).abs() < 1e-12);
            assert!((y - (40.5 + d * v)).abs() < 1e-12);
            assert!((d - (0.3 + 0.004 * x - 0.003 * y)).abs() < 1e-12);
        }
    }

    #[test]
    fn cap_hits_satisfy_the_disparity_equation() {
        let (cx, cy, radius, base, height) = (30.0, 20.0, 12.0, 0.5, 1.5);
        let s = surface(Shape::Cap {
            cx,
            cy,
            radius,
            base,
            height,
        });
        for (u, v) in [(0.0, 0.0), (2.0, -1.0), (-4.0, 3.0)] {
            let p = s.prepare(u, v);
            let mut hits = 0;
            for yi in 0..40 {
                for xi in 0..60 {
                    let (xv, yv) = (xi as f64 + 0.3, yi as f64 - 0.2);
                    if let Some((d, x, y)) = s.hit(&p, xv, yv, u, v) {
                        hits += 1;
                        let rho2 = (x - cx).powi(2) + (y - cy).powi(2);
                        let expected =
                            base + height * crate::float::sqrt(1.0 - rho2 / (radius * radius));
                        assert!((d - expected).abs() < 1e-9, "{d} {expected}");
                        assert!((x - (xv + d * u)).abs() < 1e-12);
                        let [x0, y0, x1, y1] = p.bounds;
                        assert!(xv >= x0 && xv <= x1 && yv >= y0 && yv <= y1);
                    }
                }
            }
            assert!(hits > 300, "{hits}");
        }
    }

    #[test]
    fn rect_bounds_contain_every_hit() {
        let s = surface(Shape::Plane {
            a: 1.0,
            b: 0.01,
            c: 0.0,
            support: Support::Rect {
                cx: 20.0,
                cy: 20.0,
                cos: libm::cos(0.3),
                sin: libm::sin(0.3),
                half_length: 8.0,
                half_width: 2.0,
            },
        });
        let p = s.prepare(-3.0, 2.0);
        for yi in 0..80 {
            for xi in 0..80 {
                let (x, y) = (xi as f64 * 0.5, yi as f64 * 0.5);
                if s.hit(&p, x, y, -3.0, 2.0).is_some() {
                    let [x0, y0, x1, y1] = p.bounds;
                    assert!(x >= x0 && x <= x1 && y >= y0 && y <= y1);
                }
            }
        }
    }

    #[test]
    fn coverage_tests_agree_with_dense_hits() {
        let cap = surface(Shape::Cap {
            cx: 20.0,
            cy: 24.0,
            radius: 9.0,
            base: 0.3,
            height: 2.0,
        });
        let bar = surface(Shape::Plane {
            a: 0.5,
            b: 0.02,
            c: -0.01,
            support: Support::Rect {
                cx: 25.0,
                cy: 20.0,
                cos: libm::cos(1.1),
                sin: libm::sin(1.1),
                half_length: 10.0,
                half_width: 1.5,
            },
        });
        let (mut covered, mut missed, mut partial) = (0, 0, 0);
        for s in [cap, bar] {
            for (u, v) in [(0.0, 0.0), (3.0, -4.0), (-2.0, 1.0)] {
                let p = s.prepare(u, v);
                for yi in 0..50 {
                    for xi in 0..50 {
                        let (x, y) = (xi as f64 + 0.1, yi as f64 - 0.2);
                        let quad = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
                            .map(|(dx, dy)| (x + dx, y + dy));
                        let mut hits = 0;
                        for k in 0..49 {
                            let sx = x + (k % 7) as f64 / 6.0 - 0.5;
                            let sy = y + (k / 7) as f64 / 6.0 - 0.5;
                            hits += usize::from(s.hit(&p, sx, sy, u, v).is_some());
                        }
                        if s.covers(&p, &quad, u, v) {
                            assert_eq!(hits, 49, "covers at {x},{y}");
                            covered += 1;
                        } else if s.misses(&p, &quad, u, v) {
                            assert_eq!(hits, 0, "misses at {x},{y}");
                            missed += 1;
                        } else {
                            partial += 1;
                        }
                    }
                }
            }
        }
        // The tests decide most pixels; only those near an outline are left to sampling.
        assert!(
            covered > 500 && missed > 5000 && partial < 1000,
            "{covered} {missed} {partial}"
        );
    }
}
