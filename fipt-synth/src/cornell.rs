//! The tiny test scenes: `cornell` and `cornell-metal` (a box room, one ceiling emitter, three
//! blocks).
use super::*;

/// The tiny test scene.
pub fn cornell() -> SynthScene {
    let block = principled(
        "glossy_block",
        rgb(0.8, 0.6, 0.1),
        Texture::Scalar(0.25),
        0.0,
    );
    cornell_box("cornell", 0.8, block)
}

/// `cornell` with a glossy floor (σ 0.3) and a gold metal block (σ 0.3) for the glossy one:
/// recovery of σ and metallic on a tiny scene.
pub fn cornell_metal() -> SynthScene {
    let block = principled(
        "gold_block",
        rgb(0.95, 0.72, 0.4),
        Texture::Scalar(0.3),
        1.0,
    );
    cornell_box("cornell-metal", 0.3, block)
}

fn cornell_box(name: &str, floor_roughness: f32, third_block: MaterialDesc) -> SynthScene {
    let mut b = Builder::new();
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0));
    let white = || principled("white", rgb(0.75, 0.75, 0.72), Texture::Scalar(0.9), 0.0);
    shell(
        &mut b,
        lo,
        hi,
        principled(
            "floor",
            rgb(0.7, 0.68, 0.62),
            Texture::Scalar(floor_roughness),
            0.0,
        ),
        white(),
        [
            principled("red", rgb(0.63, 0.07, 0.05), Texture::Scalar(0.9), 0.0),
            principled("green", rgb(0.12, 0.45, 0.09), Texture::Scalar(0.9), 0.0),
            white(),
            principled("front", rgb(0.5, 0.5, 0.55), Texture::Scalar(0.9), 0.0),
        ],
    );
    b.quad_light(
        "ceiling_light",
        [17.0, 12.0, 4.0],
        Vec3::new(-0.25, 1.99, -0.25),
        Vec3::new(0.5, 0., 0.),
        Vec3::new(0., 0., 0.5),
    );
    add_box(
        &mut b,
        principled(
            "tall_block",
            rgb(0.72, 0.7, 0.66),
            Texture::Scalar(0.95),
            0.0,
        ),
        FURNITURE,
        Vec3::new(-0.35, 0.6, -0.3),
        Vec3::new(0.25, 0.6, 0.25),
        0.3,
    );
    add_box(
        &mut b,
        principled(
            "short_block",
            rgb(0.2, 0.35, 0.7),
            Texture::Scalar(1.0),
            0.0,
        ),
        FURNITURE,
        Vec3::new(0.4, 0.25, 0.35),
        Vec3::new(0.25, 0.25, 0.25),
        -0.3,
    );
    add_box(
        &mut b,
        third_block,
        FURNITURE,
        Vec3::new(0.45, 0.2, -0.45),
        Vec3::new(0.18, 0.2, 0.18),
        0.5,
    );
    b.finish(name, lo, hi, 60f32.to_radians())
}
