//! An interactive 3D view for a report: the classes' surfaces at each time in a WebGL canvas
//! that the mouse turns (drag), pans (shift- or right-drag) and zooms (wheel), with a play
//! button and a time slider, a toggle per class with its name and colour, and the volumes at
//! the time shown beside it.
//!
//! [`render`] makes one HTML fragment: the markup, the scene as JSON, the geometry as one
//! base64 block of little-endian u16 words (positions quantised to 16 bits over the scene's
//! box, 16-bit triangle indices), and the viewer's script (`viewer.js`, written for this: WebGL
//! 1, no library, nothing fetched). Meshes are decimated by vertex clustering until the
//! geometry fits a byte budget, so a report with many times stays small enough to mail. A
//! browser without WebGL shows a note instead; the report's still pictures stay for printing.
//!
//! With a [`PlaneView`], one picture per time of an input plane (the model's labels, and the
//! contours where that time is annotated) sits below the canvas; the slider and play show the
//! time's picture. They are `<img>` elements with PNG data URIs, all decoded with the page, so
//! a change of time swaps them at once.

use super::escape;
use rustc_hash::FxHashMap;
use std::fmt::Write as _;

/// The viewer's script, inlined in every fragment.
const SCRIPT: &str = include_str!("viewer.js");

/// Styles of the fragment (the page keeps its own); hidden when printing, where the still
/// pictures stand in.
const STYLE: &str = "\
.dsv-main{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start}\
.dsv-canvas{flex:1 1 480px;min-width:0;max-width:100%;height:460px;border:1px solid #ddd;\
cursor:grab;touch-action:none}\
.dsv-side{flex:0 1 300px;min-width:0}.dsv-side table{margin-top:.5em}\
.dsv-controls{display:flex;gap:.5em;align-items:center;flex-wrap:wrap}\
.dsv-controls input{flex:1 1 120px;min-width:0}.dsv-help{color:#555;font-size:.9em}\
.dsv-plane{flex:1 1 100%;margin:0}.dsv-plane img{max-width:100%;height:auto;border:1px solid #eee}\
@media print{.dsv{display:none}}";

/// Bytes of packed geometry (before base64, which adds a third) [`render`] decimates to: with
/// the still figures, a report of many times stays under 5 MB.
pub const DEFAULT_BUDGET: usize = 2_500_000;

/// One class: its name and colour (sRGB).
#[derive(Debug, Clone, PartialEq)]
pub struct Class {
    /// Shown beside its toggle.
    pub name: String,
    /// The surface's colour.
    pub color: [u8; 3],
}

/// A triangle mesh in world coordinates (any orientation: both sides are lit).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Surface {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

/// One time: each class's surface and volume.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// The time, shown as written (e.g. already rounded).
    pub time: f64,
    /// One surface per class, in the order of [`Scene::classes`] (empty where absent).
    pub surfaces: Vec<Surface>,
    /// One volume per class (`None`: not measured), in [`Scene::volume_unit`].
    pub volumes: Vec<Option<f64>>,
}

/// Pictures of one input plane that follow the slider: one per time.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneView {
    /// What the pictures show (under them).
    pub caption: String,
    /// One PNG per [`Scene::snapshots`] time, in order.
    pub pngs: Vec<Vec<u8>>,
}

/// What the view shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The classes, in order.
    pub classes: Vec<Class>,
    /// The times, in order (the slider's positions).
    pub snapshots: Vec<Snapshot>,
    /// The slider's label before the time (e.g. `time` or `cardiac phase`).
    pub time_label: String,
    /// The volumes' unit (e.g. `mL`).
    pub volume_unit: String,
    /// The plane view that follows the slider (`None`: none); one picture per snapshot.
    pub plane: Option<PlaneView>,
}

/// The view of `scene` as an HTML fragment (see the module docs), its geometry decimated to
/// [`DEFAULT_BUDGET`] bytes.
pub fn render(scene: &Scene) -> String {
    render_within(scene, DEFAULT_BUDGET)
}

/// [`render`] with the geometry decimated to `budget` bytes (before base64).
pub fn render_within(scene: &Scene, budget: usize) -> String {
    let Some(packed) = pack_within(scene, budget) else {
        return format!(
            "<p>No surface at any of the {} times: nothing to show in 3D.</p>\n",
            scene.snapshots.len()
        );
    };
    let mut h = String::new();
    let _ = write!(
        h,
        "<div class=\"dsv\">\n<style>{STYLE}</style>\n<div class=\"dsv-main\" data-dsv=\"main\">\n\
         <canvas class=\"dsv-canvas\" data-dsv=\"canvas\" aria-label=\"the classes' surfaces in \
         3D\"></canvas>\n<div class=\"dsv-side\">\n<div class=\"dsv-controls\">\
         <button type=\"button\" data-dsv=\"play\">Play</button>\
         <input type=\"range\" data-dsv=\"time\" min=\"0\" max=\"{}\" step=\"1\" value=\"0\" \
         aria-label=\"{}\"><span data-dsv=\"time-label\"></span></div>\n<table>\n<thead><tr>\
         <th>show</th><th>class</th><th>volume ({})</th></tr></thead>\n<tbody>\n",
        scene.snapshots.len().saturating_sub(1),
        escape(&scene.time_label),
        escape(&scene.volume_unit)
    );
    for c in &scene.classes {
        let [r, g, b] = c.color;
        let _ = writeln!(
            h,
            "<tr><td><input type=\"checkbox\" data-dsv=\"class\" checked aria-label=\"show {}\">\
             </td><td><span class=\"swatch\" style=\"background:#{r:02x}{g:02x}{b:02x}\"></span>\
             {}</td><td class=\"num\" data-dsv=\"volume\"></td></tr>",
            escape(&c.name),
            escape(&c.name)
        );
    }
    let _ = write!(
        h,
        "</tbody>\n</table>\n<p class=\"dsv-help\">Drag to turn, shift-drag or right-drag to \
         pan, the wheel zooms, a double click goes back to the first view. Surfaces decimated \
         to {} triangles over the {} times.</p>\n</div>\n{}</div>\n<p data-dsv=\"nogl\" hidden>\
         This browser shows no WebGL: the still pictures below show the surfaces.</p>\n\
         <script type=\"application/json\" data-dsv=\"scene\">{}</script>\n\
         <script type=\"application/octet-stream\" data-dsv=\"geometry\">{}</script>\n\
         <script>{SCRIPT}</script>\n</div>\n",
        packed.triangles,
        scene.snapshots.len(),
        plane_markup(scene),
        packed.json,
        base64::encode(&packed.bytes)
    );
    h
}

/// The plane view's markup: a figure with one `<img>` per time, all but the first hidden (the
/// script shows the slider's); empty without a plane view or with a picture missing for a time.
fn plane_markup(scene: &Scene) -> String {
    let Some(plane) = scene
        .plane
        .as_ref()
        .filter(|p| p.pngs.len() == scene.snapshots.len())
    else {
        return String::new();
    };
    let mut h = String::from("<figure class=\"dsv-plane\" data-dsv=\"plane\">");
    for (i, (png, snapshot)) in plane.pngs.iter().zip(&scene.snapshots).enumerate() {
        let _ = write!(
            h,
            "<img alt=\"{}, {} {}\"{} src=\"data:image/png;base64,{}\">",
            escape(&plane.caption),
            escape(&scene.time_label),
            snapshot.time,
            if i == 0 { "" } else { " hidden" },
            base64::encode(png)
        );
    }
    let _ = writeln!(
        h,
        "<figcaption>{}</figcaption></figure>",
        escape(&plane.caption)
    );
    h
}

/// Geometry and its description, as the script reads them.
struct Packed {
    /// The scene as JSON: classes, box, and per frame its time, volumes and meshes as
    /// `[vertex offset, vertex count, index offset, index count]` in u16 words.
    json: String,
    /// The words, little-endian.
    bytes: Vec<u8>,
    /// Triangles in all.
    triangles: usize,
}

/// Packs the scene, decimated until it fits `budget` bytes (or until the clustering lattice
/// is down to 8 cells); `None` when no frame has a triangle.
fn pack_within(scene: &Scene, budget: usize) -> Option<Packed> {
    let (lo, hi) = bounds(scene)?;
    let longest = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max).max(1e-12);
    // Undecimated first; then a clustering lattice sized from the size's ratio to the budget
    // (triangles grow with the square of the cells), shrunk until the geometry fits.
    let mut cells: Option<f64> = None;
    loop {
        let packed = pack(scene, lo, hi, cells.map(|n| longest / n));
        let fits = packed.as_ref().is_some_and(|p| p.bytes.len() <= budget);
        if fits || cells.is_some_and(|n| n <= 8.0) {
            if let Some(p) = packed {
                return Some(p);
            }
        }
        let next = match (cells, &packed) {
            (None, Some(p)) => {
                let edge = mean_edge(scene).max(longest * 1e-6);
                longest / edge * (budget as f64 / p.bytes.len() as f64).sqrt() * 0.95
            }
            (None, None) => 256.0,
            (Some(n), _) => n * 0.85,
        };
        cells = Some(next.max(8.0));
    }
}

/// The box of every vertex of every frame; `None` without a triangle.
fn bounds(scene: &Scene) -> Option<([f64; 3], [f64; 3])> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut any = false;
    for s in scene.snapshots.iter().flat_map(|f| &f.surfaces) {
        if s.triangles.is_empty() {
            continue;
        }
        any = true;
        for p in &s.positions {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] as f64);
                hi[a] = hi[a].max(p[a] as f64);
            }
        }
    }
    any.then_some((lo, hi))
}

/// The mean length of the triangles' first edges over all surfaces (the meshes' spacing).
fn mean_edge(scene: &Scene) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for s in scene.snapshots.iter().flat_map(|f| &f.surfaces) {
        for t in &s.triangles {
            let (a, b) = (s.positions[t[0] as usize], s.positions[t[1] as usize]);
            sum += (0..3)
                .map(|k| (a[k] as f64 - b[k] as f64).powi(2))
                .sum::<f64>()
                .sqrt();
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

/// Every surface, clustered on a lattice of cell `cell` when given, quantised over `lo..hi`;
/// `None` when a surface keeps more vertices than 16-bit indices reach.
fn pack(scene: &Scene, lo: [f64; 3], hi: [f64; 3], cell: Option<f64>) -> Option<Packed> {
    let step: [f64; 3] = std::array::from_fn(|a| (hi[a] - lo[a]) / 65535.0);
    let mut words: Vec<u16> = Vec::new();
    let mut frames = Vec::with_capacity(scene.snapshots.len());
    let mut triangles = 0;
    for f in &scene.snapshots {
        let mut meshes = Vec::with_capacity(scene.classes.len());
        for k in 0..scene.classes.len() {
            let empty = Surface::default();
            let s = f.surfaces.get(k).unwrap_or(&empty);
            let (positions, tris) = match cell {
                Some(c) => cluster(s, lo, c),
                None => (
                    s.positions.iter().map(|p| p.map(f64::from)).collect(),
                    s.triangles.clone(),
                ),
            };
            if positions.len() > 1 << 16 {
                return None;
            }
            let vertex_offset = words.len();
            for p in &positions {
                for a in 0..3 {
                    let q = if step[a] > 0.0 {
                        ((p[a] - lo[a]) / step[a]).round().clamp(0.0, 65535.0)
                    } else {
                        0.0
                    };
                    words.push(q as u16);
                }
            }
            let index_offset = words.len();
            words.extend(tris.iter().flatten().map(|&i| i as u16));
            triangles += tris.len();
            meshes.push(format!(
                "[{vertex_offset},{},{index_offset},{}]",
                positions.len(),
                3 * tris.len()
            ));
        }
        let volumes: Vec<String> = (0..scene.classes.len())
            .map(|k| match f.volumes.get(k).copied().flatten() {
                Some(v) if v.is_finite() => v.to_string(),
                _ => "null".into(),
            })
            .collect();
        frames.push(format!(
            "{{\"time\":{},\"volumes\":[{}],\"meshes\":[{}]}}",
            if f.time.is_finite() { f.time } else { 0.0 },
            volumes.join(","),
            meshes.join(",")
        ));
    }
    let classes: Vec<String> = scene
        .classes
        .iter()
        .map(|c| {
            format!(
                "{{\"name\":{},\"color\":[{},{},{}]}}",
                json_string(&c.name),
                c.color[0],
                c.color[1],
                c.color[2]
            )
        })
        .collect();
    let json = format!(
        "{{\"classes\":[{}],\"timeLabel\":{},\"lo\":[{},{},{}],\"step\":[{},{},{}],\
         \"frames\":[{}]}}",
        classes.join(","),
        json_string(&scene.time_label),
        lo[0],
        lo[1],
        lo[2],
        step[0],
        step[1],
        step[2],
        frames.join(",")
    );
    Some(Packed {
        json,
        bytes: words.iter().flat_map(|w| w.to_le_bytes()).collect(),
        triangles,
    })
}

/// Vertex clustering: the vertices in one cell of side `cell` (from `lo`) become one at their
/// mean; triangles that lose a corner to it are dropped. Cheap, and for a picture the small
/// changes of shape it makes are below what the eye sees at the budget.
fn cluster(s: &Surface, lo: [f64; 3], cell: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut index_of: FxHashMap<[i64; 3], u32> = FxHashMap::default();
    let mut sums: Vec<([f64; 3], u32)> = Vec::new();
    let new_index: Vec<u32> = s
        .positions
        .iter()
        .map(|p| {
            let key = std::array::from_fn(|a| ((p[a] as f64 - lo[a]) / cell).floor() as i64);
            let i = *index_of.entry(key).or_insert_with(|| {
                sums.push(([0.0; 3], 0));
                sums.len() as u32 - 1
            });
            let (sum, n) = &mut sums[i as usize];
            for a in 0..3 {
                sum[a] += p[a] as f64;
            }
            *n += 1;
            i
        })
        .collect();
    // Only vertices that a kept triangle uses, renumbered in order of first use.
    let mut used: Vec<u32> = vec![u32::MAX; sums.len()];
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for t in &s.triangles {
        let c = t.map(|v| new_index[v as usize]);
        if c[0] == c[1] || c[1] == c[2] || c[0] == c[2] {
            continue;
        }
        triangles.push(c.map(|v| {
            if used[v as usize] == u32::MAX {
                let (sum, n) = sums[v as usize];
                positions.push(sum.map(|x| x / n as f64));
                used[v as usize] = positions.len() as u32 - 1;
            }
            used[v as usize]
        }));
    }
    (positions, triangles)
}

/// `text` as a JSON string literal that is also safe inside `<script>` (`<` escaped).
fn json_string(text: &str) -> String {
    let mut out = String::from("\"");
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '<' => out.push_str("\\u003c"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed octahedron-like sphere: `n` rings of `2n` vertices (a UV sphere).
    fn sphere(centre: [f32; 3], r: f32, n: u32) -> Surface {
        let mut s = Surface::default();
        s.positions.push([centre[0], centre[1], centre[2] + r]);
        for i in 1..n {
            let th = std::f32::consts::PI * i as f32 / n as f32;
            for j in 0..2 * n {
                let ph = std::f32::consts::PI * j as f32 / n as f32;
                s.positions.push([
                    centre[0] + r * th.sin() * ph.cos(),
                    centre[1] + r * th.sin() * ph.sin(),
                    centre[2] + r * th.cos(),
                ]);
            }
        }
        s.positions.push([centre[0], centre[1], centre[2] - r]);
        let south = s.positions.len() as u32 - 1;
        let at = |i: u32, j: u32| 1 + (i - 1) * 2 * n + j % (2 * n);
        for j in 0..2 * n {
            s.triangles.push([0, at(1, j), at(1, j + 1)]);
            for i in 1..n - 1 {
                let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
                s.triangles.extend([[a, c, d], [a, d, b]]);
            }
            s.triangles.push([south, at(n - 1, j + 1), at(n - 1, j)]);
        }
        s
    }

    fn scene(n: u32, frames: usize) -> Scene {
        Scene {
            classes: vec![
                Class {
                    name: "left <ventricle>".into(),
                    color: [230, 25, 75],
                },
                Class {
                    name: "myocardium \"wall\"".into(),
                    color: [60, 180, 75],
                },
            ],
            snapshots: (0..frames)
                .map(|f| Snapshot {
                    time: f as f64 * 0.5,
                    surfaces: vec![
                        sphere([0.0; 3], 10.0 + f as f32, n),
                        sphere([25.0, 0.0, 0.0], 8.0, n),
                    ],
                    volumes: vec![Some(12.5 + f as f64), None],
                })
                .collect(),
            time_label: "time".into(),
            volume_unit: "mL".into(),
            plane: None,
        }
    }

    /// The fragment's JSON and decoded geometry.
    fn parts(html: &str) -> (String, Vec<u16>) {
        let between = |start: &str| {
            let at = html.find(start).unwrap() + start.len();
            html[at..at + html[at..].find("</script>").unwrap()].to_string()
        };
        let json = between("data-dsv=\"scene\">");
        let bytes = base64::decode(between("data-dsv=\"geometry\">")).unwrap();
        let words = bytes
            .chunks(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]))
            .collect();
        (json, words)
    }

    #[test]
    fn small_scenes_are_packed_whole_and_exactly_described() {
        let s = scene(12, 3);
        let html = render(&s);
        let (json, words) = parts(&html);
        // Undecimated: every vertex and index of every surface, 3 + 3 words per vertex and
        // triangle.
        let surfaces: usize = s
            .snapshots
            .iter()
            .flat_map(|f| &f.surfaces)
            .map(|m| 3 * m.positions.len() + 3 * m.triangles.len())
            .sum();
        assert_eq!(words.len(), surfaces);
        let first = &s.snapshots[0].surfaces[0];
        assert!(json.contains(&format!(
            "\"meshes\":[[0,{},{},{}]",
            first.positions.len(),
            3 * first.positions.len(),
            3 * first.triangles.len()
        )));
        // The first triangle's indices follow the first mesh's vertices.
        let t = 3 * first.positions.len();
        assert_eq!(&words[t..t + 3], &first.triangles[0].map(|i| i as u16));
        assert!(json.contains("\"volumes\":[12.5,null]"), "{json}");
        assert!(
            json.contains("\"name\":\"left \\u003cventricle>\""),
            "{json}"
        );
        assert!(
            json.contains("\"name\":\"myocardium \\\"wall\\\"\""),
            "{json}"
        );
        assert!(html.contains("left &lt;ventricle&gt;"));
        assert!(html.contains("background:#e6194b"));
        assert!(html.contains("max=\"2\""));
        // Nothing fetched, no markup broken by the data.
        for needle in ["http:", "https:", "src=", "href=", "url("] {
            assert!(!html.contains(needle), "{needle}");
        }
        assert_eq!(html.matches("<script").count(), 3);
        assert_eq!(html.matches("</script>").count(), 3);
    }

    #[test]
    fn large_scenes_are_decimated_under_the_budget_and_keep_every_class() {
        let s = scene(150, 6);
        let raw: usize = s
            .snapshots
            .iter()
            .flat_map(|f| &f.surfaces)
            .map(|m| 6 * m.positions.len() + 6 * m.triangles.len())
            .sum();
        let budget = 200_000;
        assert!(raw > 10 * budget, "{raw}");
        let html = render_within(&s, budget);
        let (json, words) = parts(&html);
        assert!(2 * words.len() <= budget, "{}", 2 * words.len());
        // Still spheres: every class at every time has triangles, and the quantised vertices
        // of the first lie at its radius to within a cell of the clustering.
        assert!(!json.contains(",0]"), "an empty mesh: {json}");
        let lo: Vec<f64> = number_list(&json, "\"lo\":[");
        let step: Vec<f64> = number_list(&json, "\"step\":[");
        let n = number_list(&json, "\"meshes\":[[")[1] as usize;
        for v in words[..3 * n].chunks(3) {
            let p: Vec<f64> = (0..3).map(|a| lo[a] + v[a] as f64 * step[a]).collect();
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            assert!((r - 10.0).abs() < 1.5, "{r}");
        }
    }

    fn number_list(json: &str, start: &str) -> Vec<f64> {
        let at = json.find(start).unwrap() + start.len();
        json[at..at + json[at..].find(']').unwrap()]
            .split(',')
            .map(|v| v.parse().unwrap())
            .collect()
    }

    #[test]
    fn a_plane_view_has_one_picture_per_time_and_shows_the_first() {
        let mut s = scene(6, 3);
        let html = render(&s);
        assert!(!html.contains("<figure class=\"dsv-plane\""));
        let pngs: Vec<Vec<u8>> = (0..3u8).map(|i| vec![137, 80, 78, 71, i]).collect();
        s.plane = Some(PlaneView {
            caption: "axial <z> = 0".into(),
            pngs: pngs.clone(),
        });
        let html = render(&s);
        assert_eq!(html.matches("<img ").count(), 3);
        assert_eq!(html.matches(" hidden src=").count(), 2);
        assert!(html.contains("<figcaption>axial &lt;z&gt; = 0</figcaption>"));
        for (i, png) in pngs.iter().enumerate() {
            let uri = format!("data:image/png;base64,{}", base64::encode(png));
            let at = html.find(&uri).unwrap();
            // In order of time, the first shown.
            assert_eq!(html[..at].matches("<img ").count(), i + 1);
        }
        assert!(html.contains("alt=\"axial &lt;z&gt; = 0, time 0.5\" hidden"));
        // A picture missing for a time: no plane view rather than one that skips.
        s.plane.as_mut().unwrap().pngs.pop();
        assert!(!render(&s).contains("<img "));
    }

    #[test]
    fn a_scene_without_surfaces_says_so() {
        let mut s = scene(4, 2);
        for f in &mut s.snapshots {
            f.surfaces.clear();
        }
        let html = render(&s);
        assert!(html.contains("No surface at any of the 2 times"));
        assert!(!html.contains("<canvas"));
    }
}
