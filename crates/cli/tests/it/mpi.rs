//! `coherad` under `mpirun` (the `mpi` feature: `cargo test -p coherad --features mpi`;
//! needs Open MPI's `mpirun` on the PATH, which `.ci/run` installs): rows shared among
//! ranks are one process's to the bit, balanced by work units, solves are one
//! process's solution to the bit, and a rank that fails or dies ends the run with an
//! error and no output.

use super::{bench_scene, coherad, temporaries};
use std::path::Path;
use std::process::{Command, Output};

/// `mpirun -n ranks coherad args...` (ranks may exceed the cores: oversubscribed).
fn mpirun(ranks: usize, args: &[&str]) -> Output {
    Command::new("mpirun")
        .args(["--oversubscribe", "-n", &ranks.to_string()])
        .arg(env!("CARGO_BIN_EXE_coherad"))
        .args(args)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .output()
        .expect("mpirun runs (install Open MPI)")
}

/// `args` with `--out out`.
fn writing<'a>(args: &[&'a str], out: &'a str) -> Vec<&'a str> {
    let mut all = args.to_vec();
    all.extend(["--out", out]);
    all
}

/// `coherad formfactors scene --resolution res --method exact --out out`.
fn exact_rows<'a>(scene: &'a str, res: &'a str, out: &'a str) -> Vec<&'a str> {
    let args = [
        "formfactors",
        scene,
        "--resolution",
        res,
        "--method",
        "exact",
    ];
    writing(&args, out)
}

/// One process's run of `args`, writing `out`, which must succeed.
fn run_alone(args: &[&str], out: &str) {
    let run = coherad(&writing(args, out));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{args:?}: {err}");
}

/// `mpirun -n ranks` of `args`, writing `out`, which must succeed: its standard error.
fn run_ranks(ranks: usize, args: &[&str], out: &str) -> String {
    let run = mpirun(ranks, &writing(args, out));
    let err = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(run.status.success(), "{args:?} -n {ranks}: {err}");
    err
}

#[test]
fn ranks_give_one_process_rows_to_the_bit_balanced_by_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    for (scene, res, method, ranks) in [
        ("loft.json", "12x48", "exact", &[2, 3][..]),
        ("loft.json", "12x48", "estimated", &[2, 3, 4][..]),
        ("blob_room.json", "6x24", "exact", &[2, 3][..]),
        ("cornell.json", "12x48", "estimated", &[3][..]),
    ] {
        let path = bench_scene(scene);
        let args = [
            "formfactors",
            path.to_str().unwrap(),
            "--resolution",
            res,
            "--method",
            method,
        ];
        let alone = out("alone.json");
        run_alone(&args, &alone);
        let want = std::fs::read(&alone).unwrap();
        for &n in ranks {
            let shared = out(&format!("ranks{n}.json"));
            let err = run_ranks(n, &args, &shared);
            assert!(
                std::fs::read(&shared).unwrap() == want,
                "{scene} {method} -n {n}: rows differ"
            );
            // The balance note: the largest share's work units over the mean.
            let ratio: f64 = err
                .split("the largest ")
                .nth(1)
                .and_then(|t| t.split(' ').next())
                .and_then(|t| t.parse().ok())
                .unwrap_or_else(|| panic!("no balance note: {err}"));
            if scene == "loft.json" {
                assert!(ratio <= 1.1, "{scene} {method} -n {n}: {ratio}");
            }
            std::fs::remove_file(&shared).unwrap();
        }
    }
}

#[test]
fn ranks_give_one_process_view_factors_to_the_byte() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let loft = bench_scene("loft.json");
    let cornell = bench_scene("cornell.json");
    for (scene, flags) in [
        (
            &loft,
            &[
                "--by",
                "polygon",
                "--enclosure",
                "closed",
                "--format",
                "json",
            ][..],
        ),
        (
            &loft,
            &["--by", "polygon", "--origins", "1", "--format", "mtx"][..],
        ),
        // One process streams these rows to the file as made; ranks gather them whole.
        (
            &cornell,
            &["--by", "patch", "--enclosure", "raw", "--format", "bin"][..],
        ),
    ] {
        let s = scene.to_str().unwrap();
        let mut args = vec!["viewfactors", s, "--resolution", "12x48"];
        args.extend_from_slice(flags);
        let alone = out("alone");
        run_alone(&args, &alone);
        let want = std::fs::read(&alone).unwrap();
        for n in [2, 3] {
            let shared = out(&format!("ranks{n}"));
            run_ranks(n, &args, &shared);
            assert!(
                std::fs::read(&shared).unwrap() == want,
                "{flags:?} -n {n}: differs"
            );
        }
    }
}

#[test]
fn a_rank_that_fails_or_dies_ends_the_run_with_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rows.json");
    let o = out.to_str().unwrap();
    let loft = bench_scene("loft.json");
    let l = loft.to_str().unwrap();
    // Rank 1 cannot read its scene (two programs of one job: mpirun's `:`).
    let run = two_programs(
        &exact_rows(l, "12x48", o),
        &exact_rows("/no/such/scene.json", "12x48", o),
    );
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && err.contains("rank 1: cannot read /no/such/scene.json"),
        "{err}"
    );
    assert!(!out.exists() && temporaries(dir.path()).is_empty());
    // Ranks started on different runs are refused.
    let cube = bench_scene("cube.json");
    let c = cube.to_str().unwrap();
    let run = two_programs(&exact_rows(c, "12x48", o), &exact_rows(c, "6x24", o));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && err.contains("rank 1 made rows of another run"),
        "{err}"
    );
    assert!(!out.exists());
    // Rank 1 killed (SIGKILL) while computing: the launcher ends the job.
    let mut job = Command::new("mpirun")
        .args(["--oversubscribe", "-n", "2", env!("CARGO_BIN_EXE_coherad")])
        .args(exact_rows(l, "60x240", o))
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let victim = (0..200)
        .find_map(|_| {
            std::thread::sleep(std::time::Duration::from_millis(25));
            rank_process(1, o)
        })
        .expect("rank 1 started");
    // Past MPI's start-up (a rank killed inside MPI_Init can leave mpirun waiting), and
    // well before the rows are done (about 9 s here).
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(
        job.try_wait().unwrap().is_none(),
        "the job ended before the kill"
    );
    Command::new("kill")
        .args(["-9", &victim.to_string()])
        .status()
        .unwrap();
    let ended = (0..1200).find_map(|_| {
        std::thread::sleep(std::time::Duration::from_millis(50));
        job.try_wait().unwrap()
    });
    if ended.is_none() {
        let _ = job.kill();
        panic!("mpirun had not ended 60 s after rank 1 was killed");
    }
    assert!(!ended.unwrap().success());
    assert!(!out.exists(), "a partial output");
    // (The killed rank's and rank 0's temporaries, if any, are cleared by the next write.)
    let _ = temporaries(dir.path());
    // Ranks of a matrix-free solve started with different tolerances: refused at the
    // first batch of shooters' rows, with no output.
    let solve = |tolerance: &'static str| {
        vec![
            "solve",
            l,
            "--resolution",
            "12x48",
            "--storage",
            "matrix-free",
            "--tolerance",
            tolerance,
            "--out",
            o,
        ]
    };
    let run = two_programs(&solve("1e-3"), &solve("1e-4"));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && err.contains("made rows of another run"),
        "{err}"
    );
    assert!(!out.exists());
    // Commands not shared are refused by name.
    let run = mpirun(2, &["patches", l, "--out", o]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success()
            && err.contains("only `coherad formfactors`, `viewfactors` and `solve` are shared"),
        "{err}"
    );
}

/// A solution file without its timings (which differ from run to run).
fn solution_without_timings(path: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v.as_object_mut().unwrap().remove("timings");
    v
}

#[test]
fn ranks_solve_as_one_process_does_stored_and_matrix_free() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    for (scene, flags) in [
        ("loft.json", &["--storage", "stored"][..]),
        (
            "loft.json",
            &["--storage", "stored", "--method", "estimated"][..],
        ),
        ("loft.json", &["--storage", "matrix-free"][..]),
        // Shared by rows: each rank holds only its rows (and their transposes).
        (
            "loft.json",
            &["--storage", "stored", "--solver", "jacobi"][..],
        ),
        (
            "blob_room.json",
            &[
                "--storage",
                "stored",
                "--solver",
                "jacobi",
                "--method",
                "estimated",
            ][..],
        ),
        ("blob_room.json", &["--storage", "matrix-free"][..]),
        (
            "cornell.json",
            &["--storage", "stored", "--solver", "progressive"][..],
        ),
    ] {
        let path = bench_scene(scene);
        let mut args = vec!["solve", path.to_str().unwrap(), "--resolution", "12x48"];
        args.extend_from_slice(flags);
        let alone = out("alone.json");
        run_alone(&args, &alone);
        let want = solution_without_timings(&alone);
        for n in [2, 3] {
            let shared = out(&format!("ranks{n}.json"));
            run_ranks(n, &args, &shared);
            // The same radiosities, iterations, residual and energy, to the bit.
            assert!(
                solution_without_timings(&shared) == want,
                "{scene} {flags:?} -n {n}: the solution differs"
            );
        }
    }
}

/// One job of two programs (mpirun's `:`): rank 0 runs coherad with `first`, rank 1
/// with `second`.
fn two_programs(first: &[&str], second: &[&str]) -> Output {
    Command::new("mpirun")
        .args(["--oversubscribe", "-n", "1", env!("CARGO_BIN_EXE_coherad")])
        .args(first)
        .args([":", "-n", "1", env!("CARGO_BIN_EXE_coherad")])
        .args(second)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .output()
        .expect("mpirun runs (install Open MPI)")
}

/// The pid of the coherad process of rank `rank` writing `out`, if it is running.
fn rank_process(rank: usize, out: &str) -> Option<u32> {
    std::fs::read_dir("/proc").ok()?.flatten().find_map(|e| {
        let pid: u32 = e.file_name().to_str()?.parse().ok()?;
        let dir = Path::new("/proc").join(pid.to_string());
        let cmd = std::fs::read(dir.join("cmdline")).ok()?;
        let env = std::fs::read(dir.join("environ")).ok()?;
        let has = |hay: &[u8], needle: &[u8]| hay.windows(needle.len()).any(|w| w == needle);
        let rank_var = format!("OMPI_COMM_WORLD_RANK={rank}\0");
        (has(&cmd, b"formfactors") && has(&cmd, out.as_bytes()) && has(&env, rank_var.as_bytes()))
            .then_some(pid)
    })
}
