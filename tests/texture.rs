//! Textures: mip chains built in linear light (against an independent CPU box filter), and used
//! by the rasterizer when a texture is minified (lavapipe in CI, validation on).

mod common;

use common::*;
use dvsgi::render::texture::{decode_srgb, encode_srgb, mip_chain};
use dvsgi::scene::*;
use glam::{Mat4, Vec2, Vec3};
use std::path::PathBuf;

/// A `size` x `size` checker of `cell`-texel squares in two sRGB colours.
fn checker(size: u32, cell: u32, a: [u8; 3], b: [u8; 3]) -> Vec<u8> {
    let mut out = Vec::new();
    for y in 0..size {
        for x in 0..size {
            let c = if (x / cell + y / cell) % 2 == 0 { a } else { b };
            out.extend_from_slice(&[c[0], c[1], c[2], 255]);
        }
    }
    out
}

/// Level k by a box filter of the whole 2^k x 2^k block of level 0 in linear light.
fn box_filter(src: &[u8], size: u32, k: u32) -> Vec<u8> {
    let (n, block) = (size >> k, 1u32 << k);
    let mut out = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let mut sum = [0.0f64; 3];
            for sy in y * block..(y + 1) * block {
                for sx in x * block..(x + 1) * block {
                    for (c, s) in sum.iter_mut().enumerate() {
                        *s += f64::from(decode_srgb(src[((sy * size + sx) * 4) as usize + c]));
                    }
                }
            }
            for s in sum {
                out.push(encode_srgb((s / f64::from(block * block)) as f32));
            }
            out.push(255);
        }
    }
    out
}

/// Every level of the chain of a 64 x 64 checker (8-texel cells, red and blue; then 1-texel
/// cells, black and white) equals the linear-light box filter of its whole footprint in level
/// 0, to one 8-bit step (each level is rounded to 8 bits before the next is made from it).
#[test]
fn mip_chain_of_a_checker_matches_a_linear_light_box_filter() {
    for (cell, a, b) in [(8, [255, 0, 0], [0, 0, 255]), (1, [0, 0, 0], [255, 255, 255])] {
        let src = checker(64, cell, a, b);
        let chain = mip_chain(64, 64, &src);
        assert_eq!(chain.len(), 7);
        for (k, level) in chain.iter().enumerate() {
            assert_eq!((level.width, level.height), (64 >> k, 64 >> k));
            let want = box_filter(&src, 64, k as u32);
            let worst = level.rgba8.iter().zip(&want).map(|(g, w)| (i32::from(*g) - i32::from(*w)).abs()).max();
            assert!(worst <= Some(1), "cell {cell}, level {k}: off by {worst:?}");
        }
        // Fully averaged: half of each colour in linear light (not the mean of the codes).
        let top = &chain[6].rgba8;
        let mean = |c: usize| encode_srgb((decode_srgb(a[c]) + decode_srgb(b[c])) / 2.0);
        assert_eq!(&top[..3], &[mean(0), mean(1), mean(2)], "cell {cell}");
    }
    // Black and white average to linear 0.5: sRGB 188, not 128.
    assert_eq!(encode_srgb(0.5), 188);
}

/// A textured square facing the camera under a light along the view direction, filling about
/// 38 of 48 pixels, so a 1024-texel texture is minified about 27 times.
fn textured_square(texture: Texture) -> Scene {
    let v = Vec3::new;
    let positions = vec![v(-1.0, -1.0, 0.0), v(1.0, -1.0, 0.0), v(1.0, 1.0, 0.0), v(-1.0, 1.0, 0.0)];
    let mesh = Mesh {
        name: "square".into(),
        normals: vec![v(0.0, 0.0, -1.0); 4],
        uvs: vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)],
        indices: vec![0, 2, 1, 0, 3, 2],
        material: 0,
        bounds: Aabb { min: v(-1.0, -1.0, 0.0), max: v(1.0, 1.0, 0.0) },
        positions,
    };
    Scene {
        sky: None,
        path: PathBuf::from("texture-test"),
        name: "texture test".into(),
        meshes: vec![mesh],
        objects: vec![Object {
            name: "square".into(),
            meshes: vec![0],
            transform: Mat4::IDENTITY,
            dynamic: false,
            motion: Motion::None,
        }],
        materials: vec![Material {
            name: "textured".into(),
            albedo: Vec3::ONE,
            albedo_texture: Some(0),
            mask_texture: None,
            normal_texture: None,
            relief: Relief::default(),
            specular: Vec3::ZERO,
            shininess: 1.0,
            emission: Vec3::ZERO,
        }],
        textures: vec![texture],
        camera: Camera {
            position: v(0.0, 0.0, -3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_deg: 45.0,
            near: 0.1,
            far: 10.0,
        },
        lights: vec![Light {
            name: "sun".into(),
            kind: LightKind::Directional { direction: v(0.0, 0.0, 1.0), irradiance: Vec3::splat(3.0) },
            cast_shadows: false,
            motion: Motion::None,
        }],
        settings: RenderSettings {
            width: 48,
            height: 48,
            gi: GiSettings { mode: GiMode::None, ..Default::default() },
            ..Default::default()
        },
        bounds: None,
    }
}

/// A black-and-white checker of one-texel cells, minified about 27 times, renders as the flat
/// grey of its linear-light mean (the mip chain), not as aliased black and white texels: every
/// pixel inside the square within 0.5% of the same square with a uniform texture of that grey.
#[test]
fn a_minified_checker_renders_its_linear_mean_without_aliasing() {
    let ctx = context();
    let fine = Texture {
        path: PathBuf::from("checker"),
        width: 1024,
        height: 1024,
        rgba8: checker(1024, 1, [0, 0, 0], [255, 255, 255]),
        usage: TextureUse::Color,
    };
    let g = encode_srgb(0.5);
    let grey = Texture {
        path: PathBuf::from("grey"),
        width: 1,
        height: 1,
        rgba8: vec![g, g, g, 255],
        usage: TextureUse::Color,
    };
    let (checkered, _) = render(&ctx, textured_square(fine));
    let (flat, _) = render(&ctx, textured_square(grey));
    let lum = |o: &dvsgi::render::FrameOutput, i: usize| o.radiance[i * 4..i * 4 + 3].iter().sum::<f32>();
    let (mut inside, mut worst) = (0, 0.0f32);
    for y in 8..40 {
        for x in 8..40 {
            let i = y * 48 + x;
            let (c, f) = (lum(&checkered, i), lum(&flat, i));
            assert!(f > 0.1, "pixel ({x}, {y}) is inside the lit square");
            worst = worst.max((c / f - 1.0).abs());
            inside += 1;
        }
    }
    eprintln!("{inside} pixels: worst deviation from the flat grey {:.4}", worst);
    // Measured on lavapipe: 0 with the mip chain; 1.2% with level 0 alone and 16x anisotropic
    // filtering; 61% with level 0 alone and no anisotropy (aliasing).
    assert!(worst < 0.005, "aliasing: a pixel is {worst:.4} off the mean");
    assert_no_validation_messages(&ctx);
}
