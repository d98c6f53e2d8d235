//! The whole meshing job of a model (`dynaslice mesh`; `picture --3d` shares its extraction):
//! the surfaces of some classes at each of some times, over the model's bounds, written to
//! [`MeshFiles`], with what each step cost and made. A motion model's series is the first
//! time's meshes carried through the others (`carried.rs`), marched again where that fails.

use crate::carried::{Carrier, CarryReport, Fallback};
use crate::field::LevelSets;
use crate::io::MeshFiles;
use crate::{extract, Extraction, Mesh, Options, Sampling, Stats, Surfaces};
use anyhow::Result;
use dynaslice_core::Model;
use std::path::{Path, PathBuf};
use std::time::Instant;

impl Options {
    /// The options of the command line's flags and Python's keywords, by the same names:
    /// `dense` sampling (else sparse with `safety`), `non_overlapping` surfaces (the Eq. 11
    /// partition's boundaries, else each class's own level set).
    pub fn of(
        resolution: u32,
        dense: bool,
        safety: f32,
        non_overlapping: bool,
        newton_steps: u32,
    ) -> Options {
        Options {
            resolution,
            sampling: match dense {
                true => Sampling::Dense,
                false => Sampling::Sparse { safety },
            },
            surfaces: match non_overlapping {
                true => Surfaces::Partition,
                false => Surfaces::Overlapping,
            },
            newton_steps,
        }
    }

    /// About how many bytes dense sampling of `classes` classes holds: K f32 per lattice
    /// vertex, its hash-map entry and cell list (about 48 bytes per vertex), for the
    /// (resolution + 1)³ vertices of a cube. Sparse sampling holds a small part of it.
    pub fn dense_bytes(&self, classes: usize) -> f64 {
        let vertices = (f64::from(self.resolution) + 1.0).powi(3);
        vertices * (4.0 * classes as f64 + 48.0)
    }
}

impl std::ops::AddAssign for Stats {
    fn add_assign(&mut self, other: Stats) {
        self.value_evaluations += other.value_evaluations;
        self.jacobian_evaluations += other.jacobian_evaluations;
        self.dense_evaluations += other.dense_evaluations;
        self.cells += other.cells;
        self.displacement_evaluations += other.displacement_evaluations;
    }
}

impl Stats {
    /// How many times fewer values than a dense grid's were evaluated.
    pub fn saving(&self) -> f64 {
        self.dense_evaluations as f64 / self.value_evaluations.max(1) as f64
    }
}

impl Extraction {
    /// One line on the cost of the extraction at time `t` that took `seconds`: the lattice,
    /// the evaluations against a dense grid's.
    pub fn cost(&self, t: f32, seconds: f64) -> String {
        let (lattice, stats) = (&self.lattice, &self.stats);
        format!(
            "t = {t}: {}x{}x{} cells of {:.4}, {} value + {} jacobian evaluations (dense grid: \
             {} values, {:.1}x more), {seconds:.2} s",
            lattice.cells[0],
            lattice.cells[1],
            lattice.cells[2],
            lattice.h,
            stats.value_evaluations,
            stats.jacobian_evaluations,
            stats.dense_evaluations,
            stats.saving()
        )
    }
}

impl std::fmt::Display for Stats {
    /// The evaluations against a dense grid's.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} value + {} jacobian evaluations (dense: {} values, {:.1}x more)",
            self.value_evaluations,
            self.jacobian_evaluations,
            self.dense_evaluations,
            self.saving()
        )?;
        // Only a motion model's carried series evaluates the motion alone.
        if self.displacement_evaluations > 0 {
            write!(
                f,
                ", {} displacement evaluations",
                self.displacement_evaluations
            )?;
        }
        Ok(())
    }
}

impl Mesh {
    /// One line on the mesh: vertices, triangles, enclosed volume and area, and its topology
    /// where it is not a closed manifold.
    pub fn summary(&self) -> String {
        let topology = self.topology();
        format!(
            "{} vertices, {} triangles, volume {:.6}, area {:.6}{}",
            self.positions.len(),
            self.triangles.len(),
            self.enclosed_volume(),
            self.area(),
            if topology.is_closed_manifold() {
                String::new()
            } else {
                format!(" (NOT a closed manifold: {topology:?})")
            }
        )
    }
}

/// The surfaces of `classes` (0-based channels) of `model` at world time `t` over its bounds;
/// `report` gets the line on their cost ([`Extraction::cost`]).
pub fn surfaces_at(
    model: &Model,
    t: f32,
    classes: &[usize],
    options: &Options,
    report: impl FnOnce(String),
) -> Result<Extraction> {
    let start = Instant::now();
    let extraction = extract(model, model.domain().bounds(), t, classes, options)?;
    report(extraction.cost(t, start.elapsed().as_secs_f64()));
    Ok(extraction)
}

/// One step of [`write_meshes`].
pub enum Meshed<'a> {
    /// The surfaces at one time are extracted.
    Extracted {
        /// One line on its cost ([`Extraction::cost`]).
        cost: String,
    },
    /// One class's mesh at that time is staged.
    Staged {
        /// The class (0-based channel).
        class: usize,
        /// Its name.
        name: &'a str,
        /// Its mesh.
        mesh: &'a Mesh,
        /// Where it goes.
        path: &'a Path,
    },
    /// The meshes of a motion model's first time carried to a later one (`carried.rs`).
    Carried {
        /// One line on how it went and what it cost.
        cost: String,
    },
    /// One class's carried mesh was refused at that time; it is marched instead, with no
    /// `displacement` (its vertices correspond to no other time's).
    Fallback {
        /// The class (0-based channel).
        class: usize,
        /// Its name.
        name: &'a str,
        /// The time.
        time: f32,
        /// Why.
        reason: Fallback,
    },
    /// Every class at that time is staged.
    Done,
}

impl Meshed<'_> {
    /// The step's line for a log: the extraction's cost, or the class's mesh (its number and
    /// name, [`Mesh::summary`], where it goes); `None` at the end of a time.
    pub fn line(&self) -> Option<String> {
        match self {
            Meshed::Extracted { cost } | Meshed::Carried { cost } => Some(cost.clone()),
            Meshed::Fallback {
                class,
                name,
                time,
                reason,
            } => Some(format!(
                "  class {} ({name}): not carried to t = {time}: {reason}; marched instead \
                 (no displacement array at this time)",
                class + 1
            )),
            Meshed::Staged {
                class,
                name,
                mesh,
                path,
            } => Some(format!(
                "  class {} ({name}): {} -> {}",
                class + 1,
                mesh.summary(),
                path.display()
            )),
            Meshed::Done => None,
        }
    }
}

/// Every file [`write_meshes`] writes to `files` for `times` times of `classes`: the meshes
/// and the collection, so a caller can check them all before any work.
pub fn planned_paths(
    model: &Model,
    files: &MeshFiles,
    times: usize,
    classes: &[usize],
) -> Vec<PathBuf> {
    let names: Vec<&str> = model.classes().map(|c| c.name).collect();
    (0..times)
        .flat_map(|i| classes.iter().map(move |&k| (i, k)))
        .map(|(i, k)| files.path(i, k, names[k]))
        .chain(files.collection())
        .collect()
}

/// Meshes `classes` (0-based channels) of `model` at each of `times` over its bounds and
/// stages each mesh in `files` with its class's name, label and colour (`colors`, one per
/// class of the model); `step` hears of each extraction and mesh. Returns the summed cost.
/// Nothing is in place until [`MeshFiles::finish`].
///
/// For a motion model and more than one time, the first time is marched and its meshes are
/// carried through the others ([`Carrier`]): one vertex set and one triangle list per class
/// at every time, each vertex with its `displacement` from the first time. A class whose
/// carried mesh is refused at a time ([`Fallback`]) is marched there instead, without a
/// displacement. A model without motion marches every time.
pub fn write_meshes(
    model: &Model,
    times: &[f32],
    classes: &[usize],
    colors: &[[u8; 3]],
    options: &Options,
    files: &mut MeshFiles,
    mut step: impl FnMut(Meshed),
) -> Result<Stats> {
    if model.motion().is_some() && times.len() > 1 {
        return write_carried(model, times, classes, colors, options, files, step);
    }
    let mut total = Stats::default();
    for (i, &t) in times.iter().enumerate() {
        let extraction = surfaces_at(model, t, classes, options, |cost| {
            step(Meshed::Extracted { cost })
        })?;
        total += extraction.stats;
        for (mesh, &k) in extraction.meshes.iter().zip(classes) {
            stage(model, files, (i, t), k, colors[k], mesh, &mut step)?;
        }
        step(Meshed::Done);
    }
    Ok(total)
}

/// Stages `mesh` of class `k` at the `i`-th time, world time `t`, telling `step`.
fn stage(
    model: &Model,
    files: &mut MeshFiles,
    (i, t): (usize, f32),
    k: usize,
    color: [u8; 3],
    mesh: &Mesh,
    step: &mut impl FnMut(Meshed),
) -> Result<()> {
    let class = model.class(k as u32 + 1)?;
    let path = files.path(i, k, class.name);
    step(Meshed::Staged {
        class: k,
        name: class.name,
        mesh,
        path: &path,
    });
    files.write(i, t, k, class, color, mesh)
}

/// [`write_meshes`] of a motion model over several times: the first time marched, the others
/// carried, marched again per class where carrying is refused.
fn write_carried(
    model: &Model,
    times: &[f32],
    classes: &[usize],
    colors: &[[u8; 3]],
    options: &Options,
    files: &mut MeshFiles,
    mut step: impl FnMut(Meshed),
) -> Result<Stats> {
    let t0 = times[0];
    let first = surfaces_at(model, t0, classes, options, |cost| {
        step(Meshed::Extracted { cost })
    })?;
    let mut total = first.stats;
    let lattice = first.lattice;
    let mut carriers = Vec::with_capacity(classes.len());
    let field = LevelSets::new(
        model,
        t0,
        classes.to_vec(),
        options.surfaces,
        lattice.clip_box(),
    );
    for (c, (mesh, &k)) in first.meshes.into_iter().zip(classes).enumerate() {
        total.displacement_evaluations += mesh.positions.len() as u64;
        let carrier = Carrier::new(model, mesh, &field, c, lattice.h, t0);
        stage(
            model,
            files,
            (0, t0),
            k,
            colors[k],
            &carrier.reference(),
            &mut step,
        )?;
        carriers.push(carrier);
    }
    step(Meshed::Done);
    for (i, &t) in times.iter().enumerate().skip(1) {
        let start = Instant::now();
        let field = LevelSets::new(
            model,
            t,
            classes.to_vec(),
            options.surfaces,
            lattice.clip_box(),
        );
        let (outcomes, reports): (Vec<_>, Vec<_>) = carriers
            .iter_mut()
            .enumerate()
            .map(|(c, carrier)| carrier.carry(model, &field, c, lattice.h, t))
            .unzip();
        for r in &reports {
            total.displacement_evaluations += r.displacement_evaluations;
            total.jacobian_evaluations += r.jacobian_evaluations;
        }
        let carried: Vec<CarryReport> = outcomes
            .iter()
            .zip(&reports)
            .filter(|(o, _)| o.is_ok())
            .map(|(_, r)| *r)
            .collect();
        step(Meshed::Carried {
            cost: carried_cost(t, &carried, classes.len(), start.elapsed().as_secs_f64()),
        });
        let refused: Vec<usize> = (0..classes.len())
            .filter(|&c| outcomes[c].is_err())
            .collect();
        for &c in &refused {
            if let Err(reason) = outcomes[c] {
                let name = model.class(classes[c] as u32 + 1)?.name;
                step(Meshed::Fallback {
                    class: classes[c],
                    name,
                    time: t,
                    reason,
                });
            }
        }
        let marched = match refused.is_empty() {
            true => {
                total.dense_evaluations += lattice.vertex_count();
                Vec::new()
            }
            false => {
                let channels: Vec<usize> = refused.iter().map(|&c| classes[c]).collect();
                let extraction = surfaces_at(model, t, &channels, options, |cost| {
                    step(Meshed::Extracted { cost })
                })?;
                total += extraction.stats;
                extraction.meshes
            }
        };
        let mut marched = marched.into_iter();
        for (c, outcome) in outcomes.into_iter().enumerate() {
            let mesh = match outcome {
                Ok(mesh) => mesh,
                Err(_) => marched.next().expect("one marched mesh per refused class"),
            };
            stage(
                model,
                files,
                (i, t),
                classes[c],
                colors[classes[c]],
                &mesh,
                &mut step,
            )?;
        }
        step(Meshed::Done);
    }
    Ok(total)
}

/// The log line of one carried time: how many classes were carried, the fixed point's
/// iterations, the farthest projection and the largest distance left from the surface.
fn carried_cost(t: f32, reports: &[CarryReport], classes: usize, seconds: f64) -> String {
    let most = |f: fn(&CarryReport) -> f64| reports.iter().map(f).fold(0.0, f64::max);
    let how = match reports.is_empty() {
        true => String::new(),
        false => format!(
            " (fixed point ≤ {} iterations, projection ≤ {:.3} cells, |F|/‖∇F‖ ≤ {:.2e} after)",
            most(|r| f64::from(r.iterations)),
            most(|r| r.farthest_cells),
            most(|r| r.distance),
        ),
    };
    format!(
        "t = {t}: carried {} of {classes} classes from the first time{how}, {seconds:.2} s",
        reports.len()
    )
}
