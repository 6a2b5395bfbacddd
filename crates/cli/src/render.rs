//! `coherad render`: an image of a solution from the scene's camera or one given by
//! flags (32-bit float EXR, optional PNG preview).

use crate::context::Ctx;
use crate::exit::{Error, Outcome};
use crate::flags::RenderArgs;
use crate::moving::{made_folder, remove_stale, solution_folder, Steps};
use crate::report::say;
use rad_pipeline::images::{
    auto_exposure, radiance_of, render_image, render_to_files, write_exr, write_png,
};
use rad_pipeline::solve::read_solution;
use rad_pipeline::{Camera, RenderConfig, SceneFile, Vec3, View};
use std::path::Path;

/// `coherad render`: the solution's image from the scene's camera or the flags'.
pub fn run(ctx: &Ctx, args: &RenderArgs) -> Result<Outcome, Error> {
    if let Some(motion) = &args.motion {
        return moving(ctx, args, motion);
    }
    let scene = ctx.load(&args.scene)?;
    let RenderArgs {
        scene: _,
        solution,
        out,
        eye: _,
        look_at: _,
        up: _,
        fov: _,
        radiance,
        png,
        width: _,
        height: _,
        samples,
        shading,
        exposure,
        motion: _,
    } = args;
    check_exposure(args)?;
    let view = view(&scene, args)?;
    let mut b = read_solution(solution, &scene)?;
    if *radiance {
        b = radiance_of(&b);
    }
    let config = RenderConfig {
        samples: *samples,
        shading: shading.shading(),
    };
    render_to_files(
        &scene.scene,
        &b,
        &view,
        &config,
        out,
        png.as_deref(),
        *exposure,
    )?;
    Ok(Outcome::Done)
}

/// `--exposure` is the PNG's: refused without `--png`, or not finite and positive.
fn check_exposure(args: &RenderArgs) -> Result<(), Error> {
    if let Some(x) = args.exposure {
        if args.png.is_none() {
            return Err(Error::Flags(
                "--exposure sets the PNG preview's exposure: give --png too".into(),
            ));
        }
        if !(x.is_finite() && x > 0.0) {
            return Err(Error::Flags(format!(
                "--exposure must be finite and > 0, not {x}"
            )));
        }
    }
    Ok(())
}

/// The view the flags ask for of `scene`.
fn view(scene: &SceneFile, args: &RenderArgs) -> Result<View, Error> {
    let flags = CameraFlags {
        eye: args.eye.as_deref(),
        look_at: args.look_at.as_deref(),
        up: args.up.as_deref(),
        fov: args.fov,
    };
    let camera = camera(scene, &flags)?;
    Ok(View::new(&camera, args.width, args.height).map_err(rad_pipeline::Error::from)?)
}

/// Over a motion: one image a step into the folder `--out` (and a PNG into the folder
/// `--png`), each step's solution read from the folder `--solution` (as `solve
/// --motion` wrote it) against that step's scene; one camera, and the PNGs at the
/// first step's exposure, so that the steps compare.
fn moving(ctx: &Ctx, args: &RenderArgs, motion: &Path) -> Result<Outcome, Error> {
    check_exposure(args)?;
    let solutions = solution_folder(Some(&args.solution))?.expect("given");
    let steps = Steps::load(ctx, &args.scene, motion)?;
    let view = view(&steps.scene, args)?;
    let dir = &args.out;
    made_folder("--out", dir)?;
    if let Some(png) = &args.png {
        made_folder("--png", png)?;
    }
    let config = RenderConfig {
        samples: args.samples,
        shading: args.shading.shading(),
    };
    let mut exposure = args.exposure;
    for k in 0..steps.motion.steps.len() {
        let scene = steps.scene(k)?;
        let mut b = read_solution(&Steps::file(solutions, k, "json"), &scene)?;
        if args.radiance {
            b = radiance_of(&b);
        }
        let img = render_image(&scene.scene, &b, &view, &config)?;
        let exr = Steps::file(dir, k, "exr");
        write_exr(&exr, &img)?;
        let mut line = format!("step {k}: {}", exr.display());
        if let Some(png) = &args.png {
            let x = *exposure.get_or_insert_with(|| auto_exposure(&img));
            let path = Steps::file(png, k, "png");
            write_png(&path, &img, x)?;
            line += &format!(", {} (exposure {x:.4})", path.display());
        }
        say!(ctx.report, "{line}");
    }
    let n = steps.motion.steps.len();
    remove_stale(ctx.report, dir, n, &["exr"])?;
    if let Some(png) = &args.png {
        remove_stale(ctx.report, png, n, &["png"])?;
    }
    Ok(Outcome::Done)
}

/// `coherad render`'s camera flags.
struct CameraFlags<'a> {
    eye: Option<&'a str>,
    look_at: Option<&'a str>,
    up: Option<&'a str>,
    fov: Option<f32>,
}

/// A vector from "X,Y,Z".
fn parse_vec3(flag: &str, text: &str) -> Result<[f32; 3], Error> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let values: Option<Vec<f32>> = parts
        .iter()
        .map(|p| p.parse::<f32>().ok().filter(|v| v.is_finite()))
        .collect();
    match values {
        Some(v) if v.len() == 3 => Ok([v[0], v[1], v[2]]),
        _ => Err(Error::Flags(format!(
            "{flag} {text:?}: give three finite numbers X,Y,Z"
        ))),
    }
}

/// The camera of a render: the scene's, with whatever the flags override; a scene
/// without one needs --eye and --look-at.
fn camera(scene: &SceneFile, f: &CameraFlags) -> Result<Camera, Error> {
    let own = scene.scene.camera().copied();
    let given = |flag, t: Option<&str>| t.map(|t| parse_vec3(flag, t)).transpose();
    let eye = given("--eye", f.eye)?;
    let look_at = given("--look-at", f.look_at)?;
    let up = given("--up", f.up)?;
    let v = |a: [f32; 3]| Vec3::from_array(a);
    let (position, target) = match (own, eye, look_at) {
        (_, Some(e), Some(l)) => (v(e), v(l)),
        (Some(c), e, l) => (e.map_or(c.position, v), l.map_or(c.look_at, v)),
        (None, _, _) => {
            return Err(Error::Flags(format!(
            "{} has no camera: give --eye X,Y,Z and --look-at X,Y,Z (and --up, --fov if need be)",
            scene.path.display()
        )))
        }
    };
    if let Some(x) = f.fov {
        if !(x.is_finite() && x > 0.0 && x < 180.0) {
            return Err(Error::Flags(format!("--fov {x}: give degrees in (0, 180)")));
        }
    }
    Ok(Camera {
        position,
        look_at: target,
        up: up.map(v).or(own.map(|c| c.up)).unwrap_or(Vec3::Y),
        fov_y: f
            .fov
            .map(f32::to_radians)
            .or(own.map(|c| c.fov_y))
            .unwrap_or(50f32.to_radians()),
    })
}
