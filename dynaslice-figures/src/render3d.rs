//! Shaded 3D pictures of class surfaces, one panel per time, drawn by a software z-buffer
//! rasteriser (no GPU or GL needed, so it runs on any machine and in CI).
//!
//! Every panel uses the same camera and framing (all meshes of all panels fit: their extent
//! on screen for the orthographic camera, their bounding sphere for the perspective one), so
//! motion between times shows as motion in the picture. Shading is Lambert under a
//! light at the camera plus a little ambient light, interpolated per pixel from the vertex
//! normals (computed from the triangles when a mesh has none); both faces of a triangle are
//! lit, so open surfaces read too. Colours are [`class_color`]'s, as in every other figure.
//! A small R/A/S axis triad in each panel shows the view direction in our RAS world.

use crate::color::class_color;
use crate::legend::{self, Item};
use anyhow::{anyhow, ensure, Result};
use dynaslice_mesh::Mesh;
use dynaslice_sequence::ClassInfo;
use plotters::prelude::*;
use std::path::Path;

/// Largest panel side in pixels (bounds the z-buffer and image memory).
pub const MAX_PANEL: u32 = 2048;
/// Most panels (times) in one picture.
pub const MAX_PANELS: usize = 16;
/// Share of full brightness a surface gets facing away from the light.
const AMBIENT: f32 = 0.2;
/// Half the perspective camera's field of view.
const HALF_FOV: f64 = 15.0 * std::f64::consts::PI / 180.0;
/// Room left around the bounding sphere (fraction of its radius).
const PADDING: f64 = 1.05;
/// Room left around the scene's screen extent (fraction of its half-width), so that the axis
/// triad in a corner rarely covers a surface.
const FIT_PADDING: f64 = 1.15;
/// Layout: outer margin and the title row above each panel.
const MARGIN: u32 = 10;
const TITLE: u32 = 30;

/// The surfaces of one panel: one time.
pub struct SurfacePanel<'a> {
    /// World time, shown as the panel's title (`t = 0.250`).
    pub time: f64,
    /// (class index into the `classes` given to [`render_surfaces`], mesh in RAS world
    /// coordinates).
    pub meshes: Vec<(usize, &'a Mesh)>,
}

impl<'a> SurfacePanel<'a> {
    /// One panel per time, each with every class's mesh of that time (`meshes[i]` in class
    /// order, as `dynaslice mesh` extracts them).
    pub fn per_time(times: &[f32], meshes: &'a [Vec<Mesh>]) -> Vec<SurfacePanel<'a>> {
        times
            .iter()
            .zip(meshes)
            .map(|(&t, meshes)| SurfacePanel {
                time: f64::from(t),
                meshes: meshes.iter().enumerate().collect(),
            })
            .collect()
    }
}

/// Where the scene is seen from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Direction from the scene towards the camera, in RAS (any length but zero).
    pub from: [f64; 3],
    /// World direction shown upwards (default superior, +z).
    pub up: [f64; 3],
    /// Perspective projection (field of view 30°) instead of orthographic.
    pub perspective: bool,
}

impl Side {
    /// Every side, in the order a help text lists them.
    pub const ALL: [Side; 7] = [
        Side::Oblique,
        Side::Anterior,
        Side::Posterior,
        Side::Left,
        Side::Right,
        Side::Superior,
        Side::Inferior,
    ];

    /// The side's name in options and file names: `oblique`, `anterior`, …
    pub fn name(self) -> &'static str {
        match self {
            Side::Oblique => "oblique",
            Side::Anterior => "anterior",
            Side::Posterior => "posterior",
            Side::Left => "left",
            Side::Right => "right",
            Side::Superior => "superior",
            Side::Inferior => "inferior",
        }
    }

    /// Where the side looks from and what is up, for help texts.
    pub fn help(self) -> &'static str {
        match self {
            Side::Oblique => {
                "From the front, a little to the patient's right and above; superior up"
            }
            Side::Anterior => "From the front (+A); superior up, the patient's right on the left",
            Side::Posterior => "From behind (−A); superior up",
            Side::Left => "From the patient's left (−R); superior up",
            Side::Right => "From the patient's right (+R); superior up",
            Side::Superior => "From above (+S); anterior up, the patient's right on the right",
            Side::Inferior => {
                "From below (−S), as axial images are shown; anterior up, the patient's right \
                 on the left"
            }
        }
    }
}

impl Camera {
    /// The default view: from the front (anterior), a little to the patient's right and above,
    /// superior up, orthographic — anatomy as one faces a patient, with depth cues from the
    /// oblique angle and no perspective distortion of sizes.
    pub const ANTERIOR_OBLIQUE: Camera = Camera {
        from: [0.45, 1.0, 0.35],
        up: [0.0, 0.0, 1.0],
        perspective: false,
    };
}

/// The sides a 3D picture is seen from, in the model's RAS world ([`Camera::from_side`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// See [`Side::help`] for each side ([`Camera::ANTERIOR_OBLIQUE`]).
    Oblique,
    /// From the front.
    Anterior,
    /// From behind.
    Posterior,
    /// From the patient's left.
    Left,
    /// From the patient's right.
    Right,
    /// From above.
    Superior,
    /// From below.
    Inferior,
}

impl Camera {
    /// The orthographic camera looking from `side`.
    pub fn from_side(side: Side) -> Camera {
        const S: [f64; 3] = [0.0, 0.0, 1.0];
        const A: [f64; 3] = [0.0, 1.0, 0.0];
        let (from, up) = match side {
            Side::Oblique => return Camera::ANTERIOR_OBLIQUE,
            Side::Anterior => (A, S),
            Side::Posterior => ([0.0, -1.0, 0.0], S),
            Side::Left => ([-1.0, 0.0, 0.0], S),
            Side::Right => ([1.0, 0.0, 0.0], S),
            Side::Superior => (S, A),
            Side::Inferior => ([0.0, 0.0, -1.0], A),
        };
        Camera {
            from,
            up,
            ..Camera::ANTERIOR_OBLIQUE
        }
    }
}

impl Default for Camera {
    fn default() -> Self {
        Camera::ANTERIOR_OBLIQUE
    }
}

/// How to render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderOptions {
    /// The camera.
    pub camera: Camera,
    /// Panel side in pixels (at most [`MAX_PANEL`]).
    pub panel: u32,
    /// Background colour.
    pub background: RGBColor,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            camera: Camera::default(),
            panel: 480,
            background: WHITE,
        }
    }
}

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit(a: V3) -> Option<V3> {
    let n = dot(a, a).sqrt();
    (n > 1e-12 && n.is_finite()).then(|| a.map(|c| c / n))
}

/// The camera's orthonormal frame and the scene's framing.
struct View {
    centre: V3,
    /// Screen right, screen up, and forward (camera towards the scene).
    right: V3,
    up: V3,
    forward: V3,
    perspective: bool,
    /// Orthographic: pixels per world unit. Perspective: focal length in pixels.
    scale: f64,
    /// Perspective: camera distance from the centre.
    distance: f64,
    size: u32,
}

impl View {
    fn new(camera: &Camera, centre: V3, radius: f64, size: u32) -> Result<View> {
        let from = unit(camera.from)
            .ok_or_else(|| anyhow!("camera direction {:?} is not a direction", camera.from))?;
        let forward = from.map(|c| -c);
        let up = unit(camera.up)
            .ok_or_else(|| anyhow!("camera up {:?} is not a direction", camera.up))?;
        // Looking along `up`: take another up so the frame exists.
        let right = unit(cross(forward, up))
            .or_else(|| unit(cross(forward, [0.0, 1.0, 0.0])))
            .or_else(|| unit(cross(forward, [1.0, 0.0, 0.0])))
            .ok_or_else(|| anyhow!("no camera frame"))?;
        let up = cross(right, forward);
        let radius = radius.max(1e-9) * PADDING;
        let half = f64::from(size) / 2.0;
        let (scale, distance) = if camera.perspective {
            (half / HALF_FOV.tan(), radius / HALF_FOV.sin())
        } else {
            (half / radius, 0.0)
        };
        Ok(View {
            centre,
            right,
            up,
            forward,
            perspective: camera.perspective,
            scale,
            distance,
            size,
        })
    }

    /// Orthographic views: recentres and rescales so that the screen extent of every vertex of
    /// `panels` fills the panel (less [`FIT_PADDING`]); the bounding sphere alone leaves wide
    /// margins around flat or elongated scenes. A perspective view keeps the sphere's framing.
    fn fit(&mut self, panels: &[SurfacePanel]) {
        if self.perspective {
            return;
        }
        let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
        for p in panels
            .iter()
            .flat_map(|p| &p.meshes)
            .flat_map(|m| &m.1.positions)
        {
            let q: V3 = std::array::from_fn(|k| f64::from(p[k]) - self.centre[k]);
            for (k, axis) in [self.right, self.up].into_iter().enumerate() {
                lo[k] = lo[k].min(dot(q, axis));
                hi[k] = hi[k].max(dot(q, axis));
            }
        }
        let half_extent = 0.5 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
        // No vertex, or a single point: keep the sphere's framing.
        if !(half_extent > 1e-9 && half_extent.is_finite()) {
            return;
        }
        let (x, y) = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
        self.centre = std::array::from_fn(|k| self.centre[k] + x * self.right[k] + y * self.up[k]);
        self.scale = f64::from(self.size) / 2.0 / (half_extent * FIT_PADDING);
    }

    /// Screen position (pixels, y down) and depth (larger = farther) of world point `p`;
    /// `None` behind a perspective camera.
    fn project(&self, p: V3) -> Option<(f64, f64, f64)> {
        let q = [
            p[0] - self.centre[0],
            p[1] - self.centre[1],
            p[2] - self.centre[2],
        ];
        let (x, y, z) = (dot(q, self.right), dot(q, self.up), dot(q, self.forward));
        let half = f64::from(self.size) / 2.0;
        if self.perspective {
            let d = z + self.distance;
            (d > 1e-6 * self.distance)
                .then(|| (half + self.scale * x / d, half - self.scale * y / d, d))
        } else {
            Some((half + self.scale * x, half - self.scale * y, z))
        }
    }
}

/// Vertex normals of `mesh`: its own when it has one per vertex, else area-weighted triangle
/// normals (indices already checked).
fn vertex_normals(mesh: &Mesh) -> Vec<V3> {
    if mesh.normals.len() == mesh.positions.len() {
        return mesh.normals.iter().map(|n| n.map(f64::from)).collect();
    }
    let mut normals = vec![[0.0; 3]; mesh.positions.len()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize].map(f64::from));
        let n = cross(
            [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
            [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
        );
        for &i in t {
            let v = &mut normals[i as usize];
            (0..3).for_each(|k| v[k] += n[k]);
        }
    }
    normals
}

/// Rasterises one panel's meshes into a `size`×`size` RGB buffer.
fn render_panel(
    panel: &SurfacePanel,
    classes: &[ClassInfo],
    view: &View,
    background: RGBColor,
) -> Vec<u8> {
    let size = view.size as usize;
    let mut rgb = [background.0, background.1, background.2].repeat(size * size);
    let mut depth = vec![f64::INFINITY; size * size];
    let light = view.forward.map(|c| -c);
    for &(class, mesh) in &panel.meshes {
        let colour = class_color(class, classes.get(class).and_then(|c| c.color));
        let base = [colour.0, colour.1, colour.2].map(f32::from);
        let normals = vertex_normals(mesh);
        let projected: Vec<Option<(f64, f64, f64)>> = mesh
            .positions
            .iter()
            .map(|p| view.project(p.map(f64::from)))
            .collect();
        for t in &mesh.triangles {
            let [Some(a), Some(b), Some(c)] = t.map(|i| projected[i as usize]) else {
                continue;
            };
            let area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
            if area.is_nan() || area.abs() <= 1e-12 {
                continue;
            }
            let n = t.map(|i| normals[i as usize]);
            let lo_x = a.0.min(b.0).min(c.0).floor().max(0.0);
            let hi_x = a.0.max(b.0).max(c.0).ceil().min(size as f64 - 1.0);
            let lo_y = a.1.min(b.1).min(c.1).floor().max(0.0);
            let hi_y = a.1.max(b.1).max(c.1).ceil().min(size as f64 - 1.0);
            if !(lo_x <= hi_x && lo_y <= hi_y) {
                continue;
            }
            for y in lo_y as usize..=hi_y as usize {
                let py = y as f64 + 0.5;
                for x in lo_x as usize..=hi_x as usize {
                    let px = x as f64 + 0.5;
                    // Barycentric weights from edge functions, positive inside for either
                    // winding (both faces are drawn).
                    let w0 = ((b.0 - px) * (c.1 - py) - (b.1 - py) * (c.0 - px)) / area;
                    let w1 = ((c.0 - px) * (a.1 - py) - (c.1 - py) * (a.0 - px)) / area;
                    let w2 = 1.0 - w0 - w1;
                    if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                        continue;
                    }
                    // Perspective-correct weights: screen weights over depth.
                    let w = if view.perspective {
                        let s = [w0 / a.2, w1 / b.2, w2 / c.2];
                        let total = s[0] + s[1] + s[2];
                        s.map(|v| v / total)
                    } else {
                        [w0, w1, w2]
                    };
                    let z = w[0] * a.2 + w[1] * b.2 + w[2] * c.2;
                    let at = y * size + x;
                    if z >= depth[at] {
                        continue;
                    }
                    depth[at] = z;
                    let normal: V3 =
                        std::array::from_fn(|k| w[0] * n[0][k] + w[1] * n[1][k] + w[2] * n[2][k]);
                    let lambert = unit(normal).map_or(0.0, |m| dot(m, light).abs()) as f32;
                    let shade = AMBIENT + (1.0 - AMBIENT) * lambert;
                    for k in 0..3 {
                        rgb[3 * at + k] = (base[k] * shade).round().clamp(0.0, 255.0) as u8;
                    }
                }
            }
        }
    }
    rgb
}

/// The bounding sphere (centre, radius) of every vertex of every panel, after checking that
/// every mesh is well formed.
fn framing(panels: &[SurfacePanel], path: &Path) -> Result<(V3, f64)> {
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for panel in panels {
        for &(class, mesh) in &panel.meshes {
            let n = mesh.positions.len();
            ensure!(
                mesh.triangles.iter().flatten().all(|&i| (i as usize) < n),
                "cannot draw {}: at t = {}, the mesh of class {} has a triangle beyond its {n} \
                 vertices",
                path.display(),
                panel.time,
                class + 1
            );
            for p in &mesh.positions {
                ensure!(
                    p.iter().all(|c| c.is_finite()),
                    "cannot draw {}: at t = {}, the mesh of class {} has a vertex {p:?}",
                    path.display(),
                    panel.time,
                    class + 1
                );
                for k in 0..3 {
                    lo[k] = lo[k].min(f64::from(p[k]));
                    hi[k] = hi[k].max(f64::from(p[k]));
                }
            }
        }
    }
    if lo[0] > hi[0] {
        // Nothing to draw: frame the origin; the panels show the background.
        return Ok(([0.0; 3], 1.0));
    }
    let centre = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let radius = 0.5 * (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    Ok((centre, radius))
}

/// Panels of a 3D picture of a moving model by default: enough to see the motion, few enough
/// to stay readable side by side.
pub const DEFAULT_TIMES: usize = 4;

/// The default times of a 3D picture of a model moving over `t0..t1`: [`DEFAULT_TIMES`]
/// evenly, both ends included.
pub fn default_times(t0: f32, t1: f32) -> Vec<f32> {
    let n = DEFAULT_TIMES;
    (0..n)
        .map(|i| t0 + (t1 - t0) * i as f32 / (n - 1) as f32)
        .collect()
}

/// The whole 3D picture of a model: every class of `model` meshed at each of `times` over its
/// bounds with `mesh` (the extraction of `dynaslice mesh`), rendered with `options` into a
/// PNG at `path` put in place whole, one panel per time; `classes` name and colour the
/// classes. `on_time` gets each time's extraction cost ([`dynaslice_mesh::Extraction::cost`]).
pub fn draw_model(
    model: &dynaslice_core::Model,
    classes: &[ClassInfo],
    times: &[f32],
    mesh: &dynaslice_mesh::Options,
    options: &RenderOptions,
    path: &Path,
    mut on_time: impl FnMut(String),
) -> Result<()> {
    let channels: Vec<usize> = (0..model.num_classes()).collect();
    let meshes = times
        .iter()
        .map(|&t| {
            let extraction = dynaslice_mesh::surfaces_at(model, t, &channels, mesh, &mut on_time)?;
            Ok(extraction.meshes)
        })
        .collect::<Result<Vec<_>>>()?;
    let panels = SurfacePanel::per_time(times, &meshes);
    dynaslice_output::write_via(path, |tmp| render_surfaces(tmp, &panels, classes, options))
}

/// Renders the class surfaces of `panels` (one per time, side by side, titled with the time)
/// with a legend of the classes drawn, into a PNG written atomically. `classes` gives each
/// class index its name, label and colour (a class index past its end is named by number).
pub fn render_surfaces(
    path: &Path,
    panels: &[SurfacePanel],
    classes: &[ClassInfo],
    options: &RenderOptions,
) -> Result<()> {
    crate::plot::register_font();
    let err = |e: &dyn std::fmt::Display| anyhow!("cannot draw {}: {e}", path.display());
    ensure!(
        (1..=MAX_PANELS).contains(&panels.len()),
        "cannot draw {}: {} panels (1 to {MAX_PANELS})",
        path.display(),
        panels.len()
    );
    ensure!(
        (16..=MAX_PANEL).contains(&options.panel),
        "cannot draw {}: panel size {} (16 to {MAX_PANEL} pixels)",
        path.display(),
        options.panel
    );
    let (centre, radius) = framing(panels, path)?;
    let mut view =
        View::new(&options.camera, centre, radius, options.panel).map_err(|e| err(&e))?;
    view.fit(panels);

    let mut drawn: Vec<usize> = panels
        .iter()
        .flat_map(|p| p.meshes.iter().map(|m| m.0))
        .collect();
    drawn.sort_unstable();
    drawn.dedup();
    let items: Vec<Item> = drawn
        .iter()
        .map(|&k| Item {
            label: match classes.get(k) {
                Some(c) => format!("{} ({})", c.name, c.label),
                None => format!("class {}", k + 1),
            },
            fill: Some(class_color(k, classes.get(k).and_then(|c| c.color))),
            line: None,
        })
        .collect();
    let size = options.panel;
    let width = MARGIN + panels.len() as u32 * (size + MARGIN);
    let layout = legend::across(&items, width - 2 * MARGIN);
    let width = width.max(layout.width() + 2 * MARGIN);
    let legend_top = TITLE + size + MARGIN;
    let height = legend_top + layout.height() + MARGIN;
    let mut buffer = crate::canvas(path, width, height)?;
    for (i, panel) in panels.iter().enumerate() {
        let rgb = render_panel(panel, classes, &view, options.background);
        let x0 = (MARGIN + i as u32 * (size + MARGIN)) as usize;
        for row in 0..size as usize {
            let from = row * size as usize * 3;
            let to = ((TITLE as usize + row) * width as usize + x0) * 3;
            buffer[to..to + size as usize * 3]
                .copy_from_slice(&rgb[from..from + size as usize * 3]);
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (width, height)).into_drawing_area();
        let d = |r: Result<(), DrawingAreaErrorKind<_>>| r.map_err(|e| err(&e));
        for (i, panel) in panels.iter().enumerate() {
            let x0 = (MARGIN + i as u32 * (size + MARGIN)) as i32;
            d(root.draw(&Text::new(
                format!("t = {:.3}", panel.time),
                (x0, 6),
                ("sans-serif", 20),
            )))?;
            // Axis triad, bottom left: where R, A and S point on screen.
            let origin = (x0 + 34, (TITLE + size) as i32 - 34);
            for (axis, letter) in [
                ([1.0, 0.0, 0.0], "R"),
                ([0.0, 1.0, 0.0], "A"),
                ([0.0, 0.0, 1.0], "S"),
            ] {
                let (sx, sy) = (dot(axis, view.right), -dot(axis, view.up));
                let tip = (origin.0 + (24.0 * sx) as i32, origin.1 + (24.0 * sy) as i32);
                d(root.draw(&PathElement::new(vec![origin, tip], BLACK.stroke_width(2))))?;
                d(root.draw(&Text::new(
                    letter,
                    (
                        origin.0 + (30.0 * sx) as i32 - 4,
                        origin.1 + (30.0 * sy) as i32 - 7,
                    ),
                    ("sans-serif", 14),
                )))?;
            }
            d(root.draw(&Rectangle::new(
                [
                    (x0, TITLE as i32),
                    (x0 + size as i32, (TITLE + size) as i32),
                ],
                RGBColor(200, 200, 200).stroke_width(1),
            )))?;
        }
        d(legend::draw(
            &root,
            (MARGIN as i32, legend_top as i32),
            &items,
            layout,
        ))?;
        root.present().map_err(|e| err(&e))?;
    }
    crate::save_png(path, &buffer, width, height)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`Mesh::uv_sphere`] with `n` rings and `2n` segments.
    fn sphere(centre: [f32; 3], radius: f32, n: u32) -> Mesh {
        Mesh::uv_sphere(centre, radius, n, 2 * n)
    }

    fn class(name: &str, color: [u8; 3]) -> ClassInfo {
        ClassInfo {
            name: name.into(),
            label: 1,
            color: Some(color),
        }
    }

    fn px(rgb: &[u8], size: u32, x: u32, y: u32) -> [u8; 3] {
        let at = 3 * (y * size + x) as usize;
        [rgb[at], rgb[at + 1], rgb[at + 2]]
    }

    const FRONT: Camera = Camera {
        from: [0.0, 1.0, 0.0],
        up: [0.0, 0.0, 1.0],
        perspective: false,
    };

    #[test]
    fn a_sphere_is_a_shaded_disc_on_the_background() {
        let mesh = sphere([10.0, -5.0, 3.0], 20.0, 48);
        let classes = [class("ball", [200, 100, 0])];
        for perspective in [false, true] {
            let camera = Camera {
                perspective,
                ..FRONT
            };
            let panel = SurfacePanel {
                time: 0.0,
                meshes: vec![(0, &mesh)],
            };
            let (centre, radius) = framing(std::slice::from_ref(&panel), Path::new("x")).unwrap();
            let size = 200;
            let view = View::new(&camera, centre, radius, size).unwrap();
            let rgb = render_panel(&panel, &classes, &view, WHITE);
            // The disc's radius in pixels: the bounding sphere (radius √3·20) fills the panel.
            let disc = if perspective {
                let d = view.distance;
                let r = 20.0_f64;
                view.scale * r / (d * d - r * r).sqrt()
            } else {
                view.scale * 20.0
            };
            let c = size / 2;
            // Head-on light: the centre is the full class colour, the rim much darker.
            assert_eq!(
                px(&rgb, size, c, c),
                [200, 100, 0],
                "perspective {perspective}"
            );
            let rim = px(&rgb, size, c + disc as u32 - 2, c);
            assert!(rim[0] < 120 && rim[0] >= 40, "{rim:?}");
            // Shaded, never another hue: red twice green, no blue.
            assert_eq!(rim[2], 0);
            assert!(
                (i32::from(rim[0]) - 2 * i32::from(rim[1])).abs() <= 2,
                "{rim:?}"
            );
            // Outside the disc: background.
            assert_eq!(px(&rgb, size, c + disc as u32 + 3, c), [255, 255, 255]);
            assert_eq!(px(&rgb, size, 2, 2), [255, 255, 255]);
            // Inside: every pixel on the diameter is the class colour, shaded.
            for x in (c - disc as u32 + 3)..(c + disc as u32 - 3) {
                let p = px(&rgb, size, x, c);
                assert!(p[0] > 0 && p[2] == 0, "{x}: {p:?}");
            }
        }
    }

    #[test]
    fn orthographic_views_fit_the_screen_extent() {
        // Two balls one behind the other seen from the front: the bounding sphere is seven
        // times wider than what shows, a disc of radius 5 the fit makes fill the panel.
        let near = sphere([0.0, 30.0, 2.0], 5.0, 32);
        let far = sphere([0.0, -30.0, 2.0], 5.0, 32);
        let panel = SurfacePanel {
            time: 0.0,
            meshes: vec![(0, &near), (0, &far)],
        };
        let panels = std::slice::from_ref(&panel);
        let (centre, radius) = framing(panels, Path::new("x")).unwrap();
        let size = 200;
        let mut view = View::new(&FRONT, centre, radius, size).unwrap();
        view.fit(panels);
        let rgb = render_panel(&panel, &[class("ball", [0, 0, 250])], &view, WHITE);
        let disc = 100.0 / FIT_PADDING; // pixels
        let c = size / 2;
        for (x, y) in [(c, c), (c + disc as u32 - 3, c), (c, c - disc as u32 + 3)] {
            assert!(
                px(&rgb, size, x, y)[2] > 0 && px(&rgb, size, x, y)[0] == 0,
                "{x} {y}"
            );
        }
        for (x, y) in [(c + disc as u32 + 3, c), (c, c + disc as u32 + 3)] {
            assert_eq!(px(&rgb, size, x, y), [255, 255, 255], "{x} {y}");
        }
        // A perspective camera keeps the bounding sphere's framing.
        let camera = Camera {
            perspective: true,
            ..FRONT
        };
        let mut view = View::new(&camera, centre, radius, size).unwrap();
        let before = view.scale;
        view.fit(panels);
        assert_eq!(view.scale, before);
    }

    #[test]
    fn the_nearer_surface_wins_the_z_buffer() {
        // Seen from +y (anterior): the sphere at y = +8 is in front of the one at y = −8.
        // Screen right is −x, so `near` (x = −6) shows right of `far` (x = +6).
        let near = sphere([-6.0, 8.0, 0.0], 10.0, 32);
        let far = sphere([6.0, -8.0, 0.0], 10.0, 32);
        let classes = [class("near", [255, 0, 0]), class("far", [0, 0, 255])];
        for order in [[0, 1], [1, 0]] {
            let meshes = [(0, &near), (1, &far)];
            let panel = SurfacePanel {
                time: 0.0,
                meshes: order.iter().map(|&i| meshes[i]).collect(),
            };
            let (centre, radius) = framing(std::slice::from_ref(&panel), Path::new("x")).unwrap();
            let view = View::new(&FRONT, centre, radius, 240).unwrap();
            let rgb = render_panel(&panel, &classes, &view, WHITE);
            // Screen position of world x = 0 (the middle of the overlap), z = 0.
            let (sx, sy, _) = view.project([0.0, 0.0, 0.0]).unwrap();
            let overlap = px(&rgb, 240, sx as u32, sy as u32);
            assert!(
                overlap[0] > 100 && overlap[2] == 0,
                "{order:?}: {overlap:?}"
            );
            // Far sphere alone, left of the overlap.
            let (fx, fy, _) = view.project([13.0, 0.0, 0.0]).unwrap();
            let p = px(&rgb, 240, fx as u32, fy as u32);
            assert!(p[2] > 40 && p[0] == 0, "{p:?}");
        }
    }

    #[test]
    fn writes_panels_per_time_with_a_legend_and_refuses_bad_requests() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.png");
        let a = sphere([0.0, 0.0, 0.0], 10.0, 16);
        let b = sphere([0.0, 0.0, 5.0], 12.0, 16);
        let panels = [
            SurfacePanel {
                time: 0.0,
                meshes: vec![(0, &a)],
            },
            SurfacePanel {
                time: 0.5,
                meshes: vec![(0, &b), (2, &a)],
            },
        ];
        let classes = [class("ventricle", [10, 20, 30])];
        let options = RenderOptions {
            panel: 160,
            ..RenderOptions::default()
        };
        render_surfaces(&path, &panels, &classes, &options).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.width(), MARGIN + 2 * (160 + MARGIN));
        // Each panel's centre shows a surface: a shade of its class colour (the second panel's
        // class-0 sphere encloses class 2's, so it is in front).
        for i in 0..2 {
            let x = MARGIN + i * (160 + MARGIN) + 80;
            let p = img.get_pixel(x, TITLE + 80).0;
            assert!(p != [255, 255, 255] && p[0] < p[1] && p[1] < p[2], "{p:?}");
        }
        // The legend swatch of class 3 (past `classes`): palette colour 2.
        let c2 = class_color(2, None);
        assert!(img.pixels().any(|p| p.0 == [c2.0, c2.1, c2.2]));

        let mut bad = a.clone();
        bad.triangles.push([0, 1, 100_000]);
        let panel = [SurfacePanel {
            time: 0.25,
            meshes: vec![(0, &bad)],
        }];
        let e = render_surfaces(&path, &panel, &classes, &options)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("r.png") && e.contains("t = 0.25") && e.contains("class 1"),
            "{e}"
        );
        let huge = RenderOptions {
            panel: 100_000,
            ..options
        };
        assert!(render_surfaces(&path, &panels, &classes, &huge).is_err());
        assert!(render_surfaces(&path, &[], &classes, &options).is_err());
        let nowhere = RenderOptions {
            camera: Camera {
                from: [0.0; 3],
                ..Camera::default()
            },
            ..options
        };
        assert!(render_surfaces(&path, &panels, &classes, &nowhere).is_err());
    }
}
