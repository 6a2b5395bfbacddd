//! Whole-scene rows by two methods, one after the other in one process, timed:
//! `cargo run --release -p rad-repro --example rows_timing -- SCENE.json [RES]
//! [exact/hierarchy,estimated/improved/hierarchy] [FIRST-END]` (the patches FIRST..END
//! alone, through `rows`, if given).
use rad_pipeline::{rows_streamed, Hemisphere, RowMethod, SceneFile};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::Path::new(&args[1]);
    let (nt, np) =
        rad_pipeline::parse_resolution(args.get(2).map_or("180x720", String::as_str)).unwrap();
    let methods = args.get(3).map_or(
        "exact/hierarchy,estimated/improved/hierarchy",
        String::as_str,
    );
    let scene = SceneFile::load(path, None).expect("scene");
    let hemi = Hemisphere::new(rad_pipeline::HemisphereConfig::exact(nt, np)).unwrap();
    for m in methods.split(',') {
        let method: RowMethod = m.parse().expect("method");
        let t = std::time::Instant::now();
        let mut rows = 0usize;
        let mut entries = 0usize;
        let mut take = |made: rad_pipeline::Rows| {
            rows += made.rows.len();
            entries += made.rows.iter().map(|r| r.entries.len()).sum::<usize>();
            Ok(())
        };
        let stats = match args.get(4) {
            None => rows_streamed(&scene.scene, &hemi, method, &|_| {}, &mut take).unwrap(),
            Some(r) => {
                let (a, b) = r.split_once('-').expect("FIRST-END");
                let ids: Vec<u32> = (a.parse().unwrap()..b.parse().unwrap()).collect();
                let made = rad_pipeline::rows(&scene.scene, &hemi, method, &ids, &|_| {}).unwrap();
                let stats = made.stats;
                take(made).unwrap();
                stats
            }
        };
        println!("{m}: {rows} rows, {entries} entries, {:.1} s; exact {} estimated {} fallback {} real rays {}", t.elapsed().as_secs_f64(), stats.exact, stats.estimated, stats.fallback_exact, stats.real_rays);
    }
}
