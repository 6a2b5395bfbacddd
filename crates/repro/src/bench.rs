//! `cargo xtask bench`: our extended measurements beyond the report, each a section
//! that can run alone: exact hemispheres of every caster as scenes grow (scaling), view
//! factors against closed forms and at scale, rows and solves shared among simulated
//! processes (ranks), estimation across polygons on meshes, moving geometry's steps
//! against whole computations (motion); and BENCH.md.

use crate::meshes::MeshEstimation;
use crate::ranks::Ranks;
use crate::scaling::Scaling;
use crate::viewfactors::ViewFactorResults;
use crate::{Error, Provenance};
use serde::Serialize;
use std::fmt::Write;

/// A section of the bench.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    Scaling,
    ViewFactors,
    Ranks,
    Meshes,
    Motion,
}

impl Section {
    pub const ALL: [Section; 5] = [
        Section::Scaling,
        Section::ViewFactors,
        Section::Ranks,
        Section::Meshes,
        Section::Motion,
    ];

    /// Its name on the command line and its file's stem.
    pub fn name(self) -> &'static str {
        match self {
            Section::Scaling => "scaling",
            Section::ViewFactors => "viewfactors",
            Section::Ranks => "ranks",
            Section::Meshes => "meshes",
            Section::Motion => "motion",
        }
    }
}

/// What a bench run measured (the sections it ran).
pub struct Bench {
    pub quick: bool,
    pub scaling: Option<Scaling>,
    pub viewfactors: Option<ViewFactorResults>,
    pub ranks: Option<Ranks>,
    pub meshes: Option<MeshEstimation>,
    pub motion: Option<crate::motion::MotionCost>,
}

/// Runs `sections`; `progress(stage, step, of)` as they go.
pub fn run(
    quick: bool,
    sections: &[Section],
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Bench, Error> {
    let runs = |s: Section| sections.contains(&s);
    Ok(Bench {
        quick,
        scaling: runs(Section::Scaling)
            .then(|| crate::scaling::run(quick, progress))
            .transpose()?,
        viewfactors: runs(Section::ViewFactors)
            .then(|| crate::viewfactors::run(quick, progress))
            .transpose()?,
        ranks: runs(Section::Ranks)
            .then(|| crate::ranks::run(quick, progress))
            .transpose()?,
        meshes: runs(Section::Meshes)
            .then(|| crate::meshes::run(quick, progress))
            .transpose()?,
        motion: runs(Section::Motion)
            .then(|| crate::motion::run(quick, progress))
            .transpose()?,
    })
}

impl Bench {
    /// scaling.json: ms a hemisphere against polygon count, every caster, every scene.
    pub fn scaling_json(&self, provenance: &Provenance) -> Option<String> {
        let section = self.scaling.as_ref()?;
        #[derive(Serialize)]
        struct S<'a> {
            provenance: &'a Provenance,
            quick: bool,
            note: &'static str,
            scaling: &'a crate::scaling::Scaling,
        }
        let r = S {
            provenance,
            quick: self.quick,
            note: "One thread. ms_per_hemisphere: median over the patches of one exact item buffer; ms_per_row: rows of whole windows around the same patches through rad_pipeline::rows (building the caster included), centres through the scene's default caster. On the mesh scenes every polygon holds one patch, so nothing is estimated within a polygon.",
            scaling: section,
        };
        Some(serde_json::to_string_pretty(&r).expect("results serialise") + "\n")
    }

    /// viewfactors.json: the closed-form suite and the surface matrices at scale.
    pub fn viewfactors_json(&self, provenance: &Provenance) -> Option<String> {
        let section = self.viewfactors.as_ref()?;
        #[derive(Serialize)]
        struct S<'a> {
            provenance: &'a Provenance,
            quick: bool,
            note: &'static str,
            viewfactors: &'a crate::viewfactors::ViewFactorResults,
        }
        let r = S {
            provenance,
            quick: self.quick,
            note: "rad_pipeline::viewfactors::view_factors by polygon; error: |value - reference| less the reference's own slack (the 96-gon discs: half the gap between the unit discs' closed form and that of discs of the 96-gon's area). Peak memory: README (/usr/bin/time -v of coherad viewfactors).",
            viewfactors: section,
        };
        Some(serde_json::to_string_pretty(&r).expect("results serialise") + "\n")
    }

    /// ranks.json: rows and solves shared among simulated processes, against one.
    pub fn ranks_json(&self, provenance: &Provenance) -> Option<String> {
        let section = self.ranks.as_ref()?;
        #[derive(Serialize)]
        struct S<'a> {
            provenance: &'a Provenance,
            quick: bool,
            note: &'static str,
            ranks: &'a crate::ranks::Ranks,
        }
        let r = S {
            provenance,
            quick: self.quick,
            note: "Processes simulated by threads of one (rad_pipeline::share::in_threads: the collectives and errors of MPI's ranks, the pipeline code coherad runs under mpirun), oversubscribed on this machine's cores. units: each process's share in work units (an exact hemisphere is 1); balance: the largest share over the mean; identical: rows, or the solution file without its timings, equal to one process's to the bit; seconds: wall time of the whole simulated run.",
            ranks: section,
        };
        Some(serde_json::to_string_pretty(&r).expect("results serialise") + "\n")
    }

    /// meshes.json: estimation across polygons on the mesh scenes.
    pub fn meshes_json(&self, provenance: &Provenance) -> Option<String> {
        let section = self.meshes.as_ref()?;
        #[derive(Serialize)]
        struct S<'a> {
            provenance: &'a Provenance,
            quick: bool,
            note: &'static str,
            meshes: &'a crate::meshes::MeshEstimation,
        }
        let r = S {
            provenance,
            quick: self.quick,
            note: "Windows across a mesh's one-patch polygons of one plane (rad_estimator::Schedule), estimates guessing facets (rad_geometry::Facets). errors: the report's measures on every window_step-th estimating window, through the hierarchy (every caster gives the same hemispheres); noise: exact against half-sector-turned exact rows. cost: one thread, medians over the estimated patches of 12 windows (an abandoned improved estimate includes its exact cast). table1: every patch's rows exact by the best caster, then estimated (improved) with centres by the same caster, one after the other in one process on all threads (rows made and dropped chunk by chunk); sample_l1: the rows of every sample_step-th patch, estimated against exact.",
            meshes: section,
        };
        Some(serde_json::to_string_pretty(&r).expect("results serialise") + "\n")
    }

    /// motion.json: steps of motions against whole computations.
    pub fn motion_json(&self, provenance: &Provenance) -> Option<String> {
        let section = self.motion.as_ref()?;
        #[derive(Serialize)]
        struct S<'a> {
            provenance: &'a Provenance,
            quick: bool,
            note: &'static str,
            motion: &'a crate::motion::MotionCost,
        }
        let r = S {
            provenance,
            quick: self.quick,
            note: "rad_pipeline::viewfactors::view_factors_over_motion (by polygon, hemispheres, one thread): each step made from the step before's item buffers, then the same step made whole (view_factors of the step's scene, in the motion's unit), in the same process, one after the other; identical: the two equal to the bit. cast_share: cells cast again (a patch cast whole counts all its cells; a cell tested against its kept polygon and the moved ones counts as cast). median_ratio: incremental over whole, the median over the steps after the first (which casts everything and codes the buffers).",
            motion: section,
        };
        Some(serde_json::to_string_pretty(&r).expect("results serialise") + "\n")
    }

    /// BENCH.md: the tables of the sections run.
    pub fn report(&self, p: &Provenance, wall_seconds: f64) -> String {
        let mut s = String::new();
        let w = &mut s;
        let _ = writeln!(w, "# coherad: extended measurements\n");
        let _ = writeln!(w, "{}", p.written_by(wall_seconds, self.quick));
        if let Some(sc) = &self.scaling {
            report_scaling(w, sc);
        }
        if let Some(v) = &self.viewfactors {
            report_viewfactors(w, v);
        }
        if let Some(r) = &self.ranks {
            report_ranks(w, r, p.nproc);
        }
        if let Some(m) = &self.meshes {
            report_meshes(w, m, p.nproc);
        }
        if let Some(m) = &self.motion {
            report_motion(w, m);
        }
        s
    }
}

/// Estimation across polygons on the mesh scenes: errors, cost, Table 1.
fn report_motion(w: &mut String, m: &crate::motion::MotionCost) {
    let _ = writeln!(
        w,
        "\n## Moving geometry (motion.json)\n\nEach step's view factors (by polygon, from hemispheres, {}x{}, {} origin a patch side) made from the step before's item buffers, then the same step made whole, one thread, one after the other in this process. Ratio: the median over the steps after the first of incremental over whole.\n\n| scene | patches | moving share of the area | steps | cells cast again (median) | incremental / whole | identical to the bit |\n|---|---:|---:|---:|---:|---:|---|",
        m.resolution[0], m.resolution[1], m.origins
    );
    for c in &m.cases {
        let mut shares: Vec<f64> = c.steps[1..].iter().map(|s| s.cast_share).collect();
        shares.sort_by(f64::total_cmp);
        let share = shares.get(shares.len() / 2).copied().unwrap_or(f64::NAN);
        let _ = writeln!(
            w,
            "| {} | {} | {:.2} % | {} | {:.1} % | {:.3} | {} |",
            c.scene,
            c.patches,
            100.0 * c.moving_share,
            c.steps.len(),
            100.0 * share,
            c.median_ratio,
            if c.steps.iter().all(|s| s.identical) {
                "yes"
            } else {
                "NO"
            }
        );
    }
}

fn report_meshes(w: &mut String, m: &MeshEstimation, cores: usize) {
    let _ = writeln!(
        w,
        "\n## Estimation on meshes (meshes.json)\n\nA mesh's triangles hold one patch each, so the report's 3 x 3 windows within a polygon estimate nothing there. Windows across polygons: neighbouring one-patch polygons of one plane (normals within 1e-3 rad) binned in cubes of about nine, the one nearest their mean cast exactly, the others estimated from it in their own frames (turned about the normal). Improved mode guesses *facets* (a mesh's flat pieces: coplanar polygons sharing edges) rather than triangles, and finds each cell's triangle where its ray meets the facet's plane. {}x{}; the exact caster is the scene's default.\n",
        m.resolution[0], m.resolution[1]
    );
    let _ = writeln!(w, "| scene | polygons | facets of several (their polygons) | windows (estimating) | patches a window | caster |");
    let _ = writeln!(w, "|---|---|---|---|---|---|");
    for s in &m.scenes {
        let _ = writeln!(
            w,
            "| {} | {} | {} ({}) | {} ({}) | {:.2} | {} |",
            s.scene,
            s.polygons,
            s.facets,
            s.polygons_in_facets,
            s.windows,
            s.estimating_windows,
            s.patches_per_window,
            s.caster
        );
    }
    let _ = writeln!(w, "\n### Errors against exact rows (the report's measures), and the cost of an estimate\n\nEvery k-th estimating window; noise: exact against half-sector-turned exact rows. Cost: one thread, medians over the estimated patches of 12 windows, ms, and over the exact hemisphere by the scene's caster.\n");
    let _ = writeln!(w, "| scene | estimated rows (every k-th window) | noise L1 mean | setting | L1 mean | L1 median | L1 max | within noise | holes | real rays | cast exactly | ms / estimate | exact ms | ratio |");
    let _ = writeln!(
        w,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for s in &m.scenes {
        for r in &s.errors.results {
            let (ms, ratio) = if r.mode == "improved" {
                (s.cost.median_ms_improved, s.cost.ratio_improved)
            } else {
                (s.cost.median_ms_faithful, s.cost.ratio_faithful)
            };
            let _ = writeln!(
                w,
                "| {} | {} (k = {}) | {:.4} | {} | {:.4} | {:.4} | {:.3} | {:.1} % | {:.1} % | {:.2} % | {} | {:.2} | {:.2} | {:.2} |",
                s.scene,
                s.errors.estimated_hemispheres,
                s.window_step,
                s.errors.noise_l1.mean,
                r.setting,
                r.l1.mean,
                r.l1.median,
                r.l1.max,
                100.0 * r.within_noise,
                100.0 * r.hole_fraction,
                100.0 * r.real_ray_fraction,
                r.fallback_exact,
                ms,
                s.cost.median_ms_exact,
                ratio
            );
        }
    }
    let _ = writeln!(w, "\n### Table 1 on meshes\n\nEvery patch's rows, exact by the scene's caster, then estimated (improved mode) with centres, real rays and fallbacks by the same caster, one after the other in this process on {cores} threads; wall time of the rows alone (made and dropped chunk by chunk). L1: the estimated rows of every k-th patch against their exact rows.\n");
    let _ = writeln!(w, "| scene | rows | exact | estimated | exact / estimated | cast exactly (centres) | estimated | fallbacks | real rays / estimate | sample L1 mean (k) | max |");
    let _ = writeln!(w, "|---|---|---|---|---|---|---|---|---|---|---|");
    for s in &m.scenes {
        let t = &s.table1;
        let _ = writeln!(
            w,
            "| {} | {} | {:.1} s | {:.1} s | {:.2} | {} | {} | {} | {:.0} | {:.4} ({}) | {:.3} |",
            s.scene,
            t.rows,
            t.exact_seconds,
            t.estimated_seconds,
            t.speedup,
            t.rows - t.estimated_hemispheres - t.fallback_exact,
            t.estimated_hemispheres,
            t.fallback_exact,
            t.real_rays_per_estimate,
            t.sample_l1.mean,
            t.sample_step,
            t.sample_l1.max
        );
    }
}

/// The simulated larger run: identity with one process and the balance.
fn report_ranks(w: &mut String, r: &Ranks, cores: usize) {
    let _ = writeln!(
        w,
        "\n## A simulated larger run (ranks.json)\n\nRows of the loft and solves of the Cornell box at {}x{} shared among 2 to {} processes simulated by threads (`rad_pipeline::share::in_threads`, oversubscribed on {} cores; the pipeline code `coherad` runs under `mpirun`), each against one process: rows, or the solution file without its timings, to the bit. Balance: the largest share's work units over the mean.\n",
        r.resolution[0],
        r.resolution[1],
        r.runs.iter().map(|x| x.processes).max().unwrap_or(0),
        cores
    );
    let _ = writeln!(
        w,
        "| run | scene | processes | identical | balance | seconds |"
    );
    let _ = writeln!(w, "|---|---|---|---|---|---|");
    for x in &r.runs {
        let _ = writeln!(
            w,
            "| {} | {} | {} | {} | {:.3} | {:.2} |",
            x.what,
            x.scene,
            x.processes,
            if x.identical { "yes" } else { "**no**" },
            x.balance,
            x.seconds
        );
    }
}

/// The view-factor section: closed forms, the cube, the matrices at scale.
fn report_viewfactors(w: &mut String, v: &ViewFactorResults) {
    let _ = writeln!(
        w,
        "\n## View factors against closed forms (viewfactors.json)\n\n`coherad viewfactors` by polygon at {}x{}, every surface 10 x 10 patches, N x N origins a patch (`hemisphere`), or `auto` (in closed form where no polygon comes between the two, else from hemispheres at the default origins); the error is |F − closed form| (for the 96-gon discs, less half the gap between the unit discs' 0.381966 and the 0.381844 of discs of the 96-gon's area).\n",
        v.resolution[0], v.resolution[1]
    );
    let head: Vec<String> = v.cases.first().map_or(Vec::new(), |c| {
        c.values
            .iter()
            .map(|o| match o.method {
                "hemisphere" => format!("origins {}", o.origins),
                m => m.to_string(),
            })
            .collect()
    });
    let _ = writeln!(w, "| case | closed form | {} |", head.join(" | "));
    let _ = writeln!(w, "|---|---|{}", "---|".repeat(head.len()));
    for c in &v.cases {
        let cells: Vec<String> = c
            .values
            .iter()
            .map(|o| format!("{:.8} ({:.1e})", o.value, o.error))
            .collect();
        let _ = writeln!(
            w,
            "| {} | {:.8} | {} |",
            c.name,
            c.reference,
            cells.join(" | ")
        );
    }
    let _ = writeln!(
        w,
        "\nThe unit cube's 36 face factors: largest error {:.1e} at the default origins, {:.1e} by auto.\n",
        v.cube_max_error, v.cube_max_error_auto
    );
    let _ = writeln!(w, "| scene | method (pairs exact, from hemispheres) | surfaces | patches | origins | hemispheres | resolution | enclosure | threads | time | nonzeros | raw max \\|1 − row sum\\| | raw reciprocity error (median, max) | largest change |");
    let _ = writeln!(
        w,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in &v.scale {
        let _ = writeln!(
            w,
            "| {} | {} ({}, {}) | {} | {} | {} | {} | {}x{} | {} | {} | {:.1} s | {} | {:.1e} | {:.1e}, {:.1e} | {:.1e} |",
            r.scene, r.method, r.exact_pairs, r.hemisphere_pairs, r.surfaces, r.patches, r.origins, r.hemispheres, r.resolution[0], r.resolution[1],
            r.enclosure, r.threads, r.seconds, r.nonzeros, r.raw_row_sum_error_max,
            r.raw_reciprocity_error_median, r.raw_reciprocity_error_max, r.max_change
        );
    }
    let _ = writeln!(w, "\nFor scale: one View3D user's 22,176-facet case took about 21 minutes on 8 threads (after running out of memory before sparse output).");
}

fn report_scaling(w: &mut String, sc: &Scaling) {
    let _ = writeln!(
        w,
        "\n## Exact hemispheres as scenes grow (scaling.json)\n\nOne thread, {}x{}, the median over {} patches of one item buffer, in ms; every caster's item buffers compared bit for bit. Rows: whole windows around the same patches, centres through the scene's default caster, ms a row.\n",
        sc.resolution[0],
        sc.resolution[1],
        sc.scenes.first().map_or(0, |s| s.hemispheres)
    );
    let _ = writeln!(w, "| scene | polygons | grid | scan | hierarchy | facets | same bits | default | exact rows | faithful rows (estimated) | improved rows (estimated) |");
    let _ = writeln!(w, "|---|---|---|---|---|---|---|---|---|---|---|");
    for s in &sc.scenes {
        let ms = |c: &str| {
            s.casters
                .iter()
                .find(|t| t.caster == c)
                .map_or(f64::NAN, |t| t.ms_per_hemisphere)
        };
        let m = |k: usize| {
            s.modes.get(k).map_or(String::new(), |m| {
                if k == 0 {
                    format!("{:.2}", m.ms_per_row)
                } else {
                    format!("{:.2} ({} of {})", m.ms_per_row, m.estimated, m.rows)
                }
            })
        };
        let _ = writeln!(
            w,
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {} | {} | {} | {} |",
            s.scene,
            s.polygons,
            ms("grid"),
            ms("scan"),
            ms("hierarchy"),
            ms("facets"),
            if s.identical { "yes" } else { "**no**" },
            s.default_caster,
            m(0),
            m(1),
            m(2)
        );
    }
}
