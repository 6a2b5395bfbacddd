//! Image files: 32-bit float RGB OpenEXR (the `exr` crate) and tone-mapped sRGB PNG
//! previews (the `png` crate), both written atomically.

use crate::output::write_atomic;
use crate::Error;
use rad_render::{luminance, Image};
use std::path::Path;

/// The image as an OpenEXR file in memory: RGB, 32-bit float, no alpha.
pub fn encode_exr(img: &Image) -> Result<Vec<u8>, Error> {
    use exr::prelude::*;
    let w = img.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = img.pixels[y * w + x];
        (p[0], p[1], p[2])
    });
    let image = exr::image::Image::from_channels((w, img.height as usize), channels);
    let mut bytes = std::io::Cursor::new(Vec::new());
    image
        .write()
        .non_parallel()
        .to_buffered(&mut bytes)
        .map_err(|e| crate::Error::Encode {
            what: "exr",
            reason: e.to_string(),
        })?;
    Ok(bytes.into_inner())
}

/// Writes `img` as 32-bit float RGB OpenEXR.
pub fn write_exr(path: &Path, img: &Image) -> Result<(), Error> {
    let bytes = encode_exr(img)?;
    write_atomic(path, |w| w.write_all(&bytes))
}

/// An exposure that maps the 95th percentile of the lit pixels' luminance to 0.8 (so
/// that lights and the brightest few per cent saturate): `1` for a black image.
pub fn auto_exposure(img: &Image) -> f32 {
    let mut l: Vec<f64> = img
        .pixels
        .iter()
        .map(|&p| luminance(p))
        .filter(|&v| v > 0.0)
        .collect();
    if l.is_empty() {
        return 1.0;
    }
    l.sort_by(f64::total_cmp);
    let p = l[((l.len() - 1) as f64 * 0.95) as usize];
    (0.8 / p) as f32
}

/// sRGB transfer of a linear value in [0, 1], to 8 bits (values outside are clipped).
pub fn srgb8(v: f32) -> u8 {
    srgb(v)
}

/// sRGB transfer of a linear value in [0, 1].
fn srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// The image scaled by `exposure`, clipped to [0, 1] and sRGB-encoded, as 8-bit PNG.
pub fn encode_png(img: &Image, exposure: f32) -> Result<Vec<u8>, Error> {
    let data: Vec<u8> = img
        .pixels
        .iter()
        .flat_map(|p| p.map(|c| srgb(c * exposure)))
        .collect();
    let mut bytes = Vec::new();
    let fail = |e: png::EncodingError| Error::Encode {
        what: "png",
        reason: e.to_string(),
    };
    {
        let mut enc = png::Encoder::new(&mut bytes, img.width, img.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = enc.write_header().map_err(fail)?;
        writer.write_image_data(&data).map_err(fail)?;
        writer.finish().map_err(fail)?;
    }
    Ok(bytes)
}

/// Writes a PNG preview of `img` at `exposure`.
pub fn write_png(path: &Path, img: &Image, exposure: f32) -> Result<(), Error> {
    let bytes = encode_png(img, exposure)?;
    write_atomic(path, |w| w.write_all(&bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient() -> Image {
        let (w, h) = (7u32, 5u32);
        Image {
            width: w,
            height: h,
            pixels: (0..w * h)
                .map(|k| [k as f32 * 0.25, 1.0 / (1.0 + k as f32), 3.5])
                .collect(),
        }
    }

    #[test]
    fn exr_round_trips_32_bit_floats() {
        use exr::prelude::*;
        let img = gradient();
        let bytes = encode_exr(&img).unwrap();
        let read = read()
            .no_deep_data()
            .largest_resolution_level()
            .rgb_channels(
                |res, _| vec![[0f32; 3]; res.width() * res.height()],
                |px: &mut Vec<[f32; 3]>, pos, (r, g, b): (f32, f32, f32)| {
                    px[pos.y() * 7 + pos.x()] = [r, g, b]
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(bytes))
            .unwrap();
        assert_eq!(read.layer_data.size, Vec2(7, 5));
        assert_eq!(read.layer_data.channel_data.pixels, img.pixels);
    }

    #[test]
    fn png_is_srgb_encoded_and_clipped() {
        let img = Image {
            width: 3,
            height: 1,
            pixels: vec![[0.0; 3], [0.5, 0.5, 0.5], [4.0, 0.0, 0.0]],
        };
        let bytes = encode_png(&img, 1.0).unwrap();
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = dec.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (3, 1));
        assert_eq!(&buf[..9], &[0, 0, 0, 188, 188, 188, 255, 0, 0]);
    }

    #[test]
    fn exposure_maps_the_95th_percentile_to_0_8() {
        let img = Image {
            width: 100,
            height: 1,
            pixels: (0..100).map(|k| [k as f32; 3]).collect(),
        };
        // Lit pixels 1..=99; the 95th percentile of 99 values is the 94th (index 93).
        assert!((auto_exposure(&img) - 0.8 / 94.0).abs() < 1e-6);
    }
}

/// Renders the radiosities `b` of `scene` from `view` (rays through the wide BVH: see
/// [`render_image`]) and writes the EXR to `exr`, and a PNG preview to `png` if given,
/// at `exposure` (else [`auto_exposure`]'s).
pub fn render_to_files(
    scene: &rad_geometry::Scene,
    b: &[[f64; 3]],
    view: &rad_render::View,
    config: &rad_render::RenderConfig,
    exr: &Path,
    png: Option<&Path>,
    exposure: Option<f32>,
) -> Result<(), Error> {
    let img = render_image(scene, b, view, config)?;
    write_exr(exr, &img)?;
    if let Some(p) = png {
        write_png(p, &img, exposure.unwrap_or_else(|| auto_exposure(&img)))?;
    }
    Ok(())
}

/// Radiance B / π of radiosities `b` (Lambertian surfaces: what a path tracer, or a
/// viewer of baked colours, shows), for `coherad render --radiance`.
pub fn radiance_of(b: &[[f64; 3]]) -> Vec<[f64; 3]> {
    b.iter()
        .map(|p| p.map(|c| c / std::f64::consts::PI))
        .collect()
}

/// From how many rays a thread, per polygon, an image goes through
/// [`rad_hemisphere::FacetRays`] rather than the wide BVH: its rays from the camera are
/// far cheaper (binned by direction from it), its build dearer (about a microsecond a
/// polygon more, on one thread).
pub const FACET_RENDER_RAYS_PER_POLYGON: u64 = 8;

/// The image of the radiosities `b` of `scene` from `view`, its rays through
/// [`rad_hemisphere::FacetRays`] (the scene's flat pieces binned by direction from the
/// camera, once, if it has [`rad_hemisphere::BIN_RAYS_PER_FACET`] rays a piece or
/// more) if the image has [`FACET_RENDER_RAYS_PER_POLYGON`] rays a thread per
/// polygon or more, else through the wide BVH ([`rad_accel::WideBvh`]), the fastest to
/// build; both give the voxel grid's hits to the bit (see `cargo bench -p rad-pipeline
/// --bench render`).
pub fn render_image(
    scene: &rad_geometry::Scene,
    b: &[[f64; 3]],
    view: &rad_render::View,
    config: &rad_render::RenderConfig,
) -> Result<rad_render::Image, Error> {
    let rays = view.width as u64 * view.height as u64 * (config.samples as u64).pow(2);
    let per_thread = rays / rayon::current_num_threads().max(1) as u64;
    if per_thread >= FACET_RENDER_RAYS_PER_POLYGON * scene.polygons().len() as u64 {
        let mut facets = rad_hemisphere::FacetRays::new(scene, rad_accel::WideTree::new);
        if facets.facet_count() as u64 * rad_hemisphere::BIN_RAYS_PER_FACET <= rays {
            // (Once for every thread: the camera's rays share its position.)
            facets = facets.bin_from(view.ray(0.5, 0.5).origin);
        }
        return Ok(rad_render::render(scene, &facets, view, b, config)?);
    }
    let bvh = rad_accel::WideBvh::new(scene);
    Ok(rad_render::render(scene, &bvh, view, b, config)?)
}

#[cfg(test)]
mod render_tests {
    /// The wide BVH, the hierarchy and the voxel grid render the same image, to the bit
    /// (the hits are the same): the Cornell box, both shadings.
    #[test]
    fn both_casters_render_the_same_image() {
        let scene = rad_geometry::Scene::new(rad_geometry::scenes::cornell_box(
            rad_geometry::scenes::CORNELL_PATCH_MM,
        ))
        .unwrap();
        let view = rad_render::View::of_scene(&scene, 48, 40).unwrap();
        let b: Vec<[f64; 3]> = (0..scene.patches().len())
            .map(|k| [k as f64, (k % 5) as f64, 1.0])
            .collect();
        let grid = rad_accel::VoxelGrid::build(&scene, &crate::default_grid()).unwrap();
        let tree = rad_hemisphere::Hierarchy::new(&scene);
        for shading in [rad_render::Shading::Flat, rad_render::Shading::Smooth] {
            let config = rad_render::RenderConfig {
                samples: 2,
                shading,
            };
            let a = rad_render::render(&scene, &grid, &view, &b, &config).unwrap();
            let h = rad_render::render(&scene, &tree.rays(&scene), &view, &b, &config).unwrap();
            assert_eq!(a, h);
            let bvh = rad_accel::WideBvh::new(&scene);
            let w = rad_render::render(&scene, &bvh, &view, &b, &config).unwrap();
            assert_eq!(a, w);
        }
    }

    /// On the loft cut into 28,800 triangles (180 flat pieces), rays through the facets
    /// render the wide BVH's image, to the bit, through the tree and binned.
    #[test]
    fn facet_rays_render_the_wide_bvh_image() {
        let scene = rad_geometry::Scene::new(rad_geometry::scenes::loft_triangles()).unwrap();
        let view = rad_render::View::of_scene(&scene, 40, 30).unwrap();
        let b: Vec<[f64; 3]> = (0..scene.patches().len())
            .map(|k| [(k % 7) as f64, (k % 11) as f64, 1.0])
            .collect();
        let facets = rad_hemisphere::FacetRays::new(&scene, rad_accel::WideTree::new);
        assert!(facets.facet_count() * 8 <= scene.polygons().len());
        let config = rad_render::RenderConfig {
            samples: 2,
            shading: rad_render::Shading::Smooth,
        };
        let bvh = rad_accel::WideBvh::new(&scene);
        let w = rad_render::render(&scene, &bvh, &view, &b, &config).unwrap();
        let f = rad_render::render(&scene, &facets, &view, &b, &config).unwrap();
        assert_eq!(w, f);
        // Binned by direction from the camera: once for all threads, and at each
        // scratch's first ray.
        let shared = rad_hemisphere::FacetRays::new(&scene, rad_accel::WideTree::new)
            .bin_from(view.ray(0.5, 0.5).origin);
        let f = rad_render::render(&scene, &shared, &view, &b, &config).unwrap();
        assert_eq!(w, f);
        let binned = facets.bin_after(1);
        let f = rad_render::render(&scene, &binned, &view, &b, &config).unwrap();
        assert_eq!(w, f);
        assert!(w.pixels.iter().any(|p| p[0] > 0.0));
    }
}
