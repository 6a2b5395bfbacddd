//! What a step of a motion costs against a whole computation of that step, in one run,
//! one thread: `cargo run --release -p rad-repro --example motion_cost -- SCENE [RES]`
//! with SCENE `satellite` (its arrays turning 10° a step), `cart:SIDE` (the room with a
//! cube cart of SIDE m sliding across it) or `blob:SIDE` (the blob room, 20,480 curved
//! triangles, with such a cart sliding along a wall). Each step's view factors (by
//! polygon, hemispheres only, ORIGINS=1 a patch side) are made incrementally, then
//! whole, and compared to the bit (`rad_repro::motion::measure`); prints each step's two
//! times, the share of cells cast again, the moving share of the area, and the median
//! ratio over the steps after the first. STEPS=4 steps of the motion; SKIP_WHOLE=1
//! makes the steps alone (to profile them).

use rad_geometry::scenes::{
    blob_room, cart_motion, room_with_cart, satellite, satellite_motion, slide, with_cart,
};
use rad_hemisphere::{Hemisphere, HemisphereConfig};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let which = args.first().map(String::as_str).unwrap_or("satellite");
    let res = args.get(1).map(String::as_str).unwrap_or("180x720");
    let env = |k: &str, d: usize| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let steps = env("STEPS", 4);
    let origins = env("ORIGINS", 1) as u32;
    let side = |s: &str| -> f32 { s.parse().expect("SCENE:SIDE in metres") };
    let (desc, mut motion, moving) = match which.split_once(':') {
        Some(("cart", s)) => (room_with_cart(side(s)), cart_motion(10), "cart"),
        Some(("blob", s)) => {
            let desc = with_cart(blob_room(), glam::Vec3::new(0.3, 0.01, 0.3), side(s), 0);
            (
                desc,
                slide("cart", glam::DVec3::new(2.5, 0.0, 0.0), 10),
                "cart",
            )
        }
        _ => (satellite(), satellite_motion(36), "array"),
    };
    motion.steps.truncate(steps);
    let (nt, np) = res.split_once('x').expect("RES as NTHETAxNPHI");
    let config = HemisphereConfig::exact(nt.parse().unwrap(), np.parse().unwrap());
    let hemi = Hemisphere::new(config).unwrap();
    let whole = std::env::var("SKIP_WHOLE").is_err();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let case = pool
        .install(|| {
            rad_repro::motion::measure(which, &desc, &motion, moving, &hemi, origins, whole)
        })
        .unwrap();
    println!(
        "{which} at {res}, {origins} origin(s) a patch side, {} patches, moving share of the area {:.2} %, one thread",
        case.patches,
        100.0 * case.moving_share
    );
    for s in &case.steps {
        println!(
            "step {:2}: incremental {:8.3} s, whole {:8.3} s, ratio {:.4}, cells cast {:6.2} %, patches whole {} in part {}",
            s.step,
            s.incremental_seconds,
            s.whole_seconds,
            s.incremental_seconds / s.whole_seconds,
            100.0 * s.cast_share,
            s.patches_whole,
            s.patches_in_part
        );
    }
    let same = case.steps.iter().all(|s| s.identical);
    println!(
        "median step / whole over steps 1..{}: {:.4} (equal to the bit: {}); kept {} bytes",
        steps - 1,
        case.median_ratio,
        if same { "yes" } else { "NO" },
        case.kept_bytes
    );
    assert!(same, "a step differs from its whole computation");
}
