//! What the binary tells people, on standard error: notes and summaries (not with
//! `--quiet`), warnings (always, but on MPI ranks other than the first, which would
//! repeat rank 0's) and progress bars on long jobs.

use indicatif::{ProgressBar, ProgressStyle};
use rad_pipeline::share::Share;
use rad_pipeline::{EstimateStats, Hemisphere, Mode, PickedMethod, RowMethod};
use std::fmt;

/// Rays over which a job shows a progress bar.
const BAR_FROM_RAYS: u64 = 50_000_000;

/// Where notes, warnings and bars go.
pub struct Report {
    /// `--quiet`, or a rank but the first: no notes, summaries or bars.
    quiet: bool,
    /// A rank but the first: no warnings either.
    silent: bool,
}

/// A note or summary on standard error, unless quiet: `say!(report, "...", args)`.
macro_rules! say {
    ($report:expr, $($arg:tt)*) => {
        $report.say(format_args!($($arg)*))
    };
}

/// A warning on standard error (even when quiet): `warning!(report, "...", args)`.
macro_rules! warning {
    ($report:expr, $($arg:tt)*) => {
        $report.warn(format_args!($($arg)*))
    };
}
pub(crate) use {say, warning};

impl Report {
    pub fn new(quiet: bool, silent: bool) -> Report {
        Report {
            quiet: quiet || silent,
            silent,
        }
    }

    pub fn say(&self, text: fmt::Arguments) {
        if !self.quiet {
            eprintln!("{text}");
        }
    }

    pub fn warn(&self, text: fmt::Arguments) {
        if !self.silent {
            eprintln!("{text}");
        }
    }

    /// A bar of `len` steps named by `unit` ("rows", "patches"), shown when the job
    /// casts over about 50 M rays and notes are on.
    pub fn bar(&self, len: usize, rays: u64, unit: &str, message: String) -> ProgressBar {
        let bar = if rays > BAR_FROM_RAYS && !self.quiet {
            ProgressBar::new(len as u64)
        } else {
            ProgressBar::hidden()
        };
        bar.set_style(
            ProgressStyle::with_template(&format!(
                "{{msg}} [{{bar:40}}] {{pos}}/{{len}} {unit}, {{elapsed}} elapsed, eta {{eta}}"
            ))
            .expect("a valid template")
            .progress_chars("=> "),
        );
        bar.set_message(message);
        bar
    }

    /// A bar for `n_rows` rows of `hemi` by `method`.
    pub fn row_bar(&self, hemi: &Hemisphere, method: RowMethod, n_rows: usize) -> ProgressBar {
        let rays = n_rows as u64 * hemi.n_cells() as u64;
        let message = format!("form factors {}x{}, {method}", hemi.n_theta(), hemi.n_phi());
        self.bar(n_rows, rays, "rows", message)
    }

    /// What `--method auto` picked, where it estimates (a scene of `n_patches`).
    pub fn picked(&self, picked: &PickedMethod, n_patches: usize) {
        if let Some(share) = picked.auto_estimated_share {
            say!(
                self,
                "method auto: estimated rows ({n_patches} patches, {:.0} % of them in windows that estimate them; --method exact casts every hemisphere)",
                100.0 * share
            );
        }
    }

    /// What a run of estimated rows did.
    pub fn estimates(&self, method: RowMethod, s: &EstimateStats) {
        if method.is_exact() {
            return;
        }
        say!(
            self,
            "{} rows cast exactly (window centres), {} estimated, {} cast exactly after needing real rays for over {:.0} % of their cells ({} real rays)",
            s.exact,
            s.estimated,
            s.fallback_exact,
            100.0 * rad_pipeline::default_estimator(Mode::Improved).max_real_ray_share,
            s.real_rays
        );
    }

    /// The work units of each rank's share, and the largest over the mean.
    pub fn balance(&self, shares: &[Share]) {
        let units: Vec<String> = shares.iter().map(|s| format!("{:.0}", s.units)).collect();
        let mean = shares.iter().map(|s| s.units).sum::<f64>() / shares.len() as f64;
        let worst = shares.iter().map(|s| s.units).fold(0.0, f64::max);
        say!(
            self,
            "mpi: {} ranks, work units {} (the largest {:.3} of the mean)",
            shares.len(),
            units.join(" / "),
            worst / mean
        );
    }
}
