//! The `room` scene: a furnished room (a sofa, a table, a lamp, a mirror, a metal sphere, a
//! glossy box) lit by a ceiling panel and the lamp's bulb.
use super::*;

/// The realistic small room.
pub fn room() -> SynthScene {
    let mut b = Builder::new();
    let (lo, hi) = (Vec3::new(-2.5, 0.0, -2.0), Vec3::new(2.5, 2.8, 2.0));
    let planks = Texture::Pattern(Pattern::Checker {
        color0: [0.55, 0.36, 0.2],
        color1: [0.4, 0.25, 0.13],
        origin: [lo.x, 0.0, lo.z],
        u_axis: [1.0 / 0.9, 0.0, 0.0],
        v_axis: [0.0, 0.0, 1.0 / 0.3],
    });
    let floor_rough = Texture::Pattern(Pattern::Checker {
        color0: [0.45; 3],
        color1: [0.7; 3],
        origin: [lo.x, 0.0, lo.z],
        u_axis: [1.0 / 0.9, 0.0, 0.0],
        v_axis: [0.0, 0.0, 1.0 / 0.3],
    });
    let wallpaper = Texture::Pattern(Pattern::Stripes {
        color0: [0.7, 0.66, 0.55],
        color1: [0.6, 0.52, 0.42],
        origin: [0.0, 0.0, 0.0],
        u_axis: [0.0, 0.0, 1.0 / 0.25],
        duty: 0.5,
    });
    shell(
        &mut b,
        lo,
        hi,
        principled("floor", planks, floor_rough, 0.0),
        principled("ceiling", rgb(0.85, 0.85, 0.83), Texture::Scalar(1.0), 0.0),
        [
            principled("wall_west", wallpaper, Texture::Scalar(0.9), 0.0),
            principled(
                "wall_east",
                rgb(0.35, 0.52, 0.4),
                Texture::Scalar(0.85),
                0.0,
            ),
            principled(
                "wall_north",
                rgb(0.76, 0.72, 0.64),
                Texture::Scalar(0.95),
                0.0,
            ),
            principled(
                "wall_south",
                rgb(0.32, 0.38, 0.6),
                Texture::Scalar(0.9),
                0.0,
            ),
        ],
    );
    room_lights(&mut b);
    room_objects(&mut b);
    b.finish("room", lo, hi, 65f32.to_radians())
}

/// The room's two lights: a ceiling panel and a floor lamp (its metal stand and a small, very
/// bright bulb).
fn room_lights(b: &mut Builder) {
    // Ceiling panel (1 cm below the ceiling).
    b.quad_light(
        "ceiling_panel",
        [9.0, 8.6, 7.8],
        Vec3::new(-0.6, 2.79, -0.3),
        Vec3::new(1.2, 0., 0.),
        Vec3::new(0., 0., 0.6),
    );
    // Floor lamp: a thin stand and a small, very bright bulb.
    let lamp = Vec3::new(-1.9, 0.0, 1.4);
    add_box(
        b,
        principled("lamp_stand", rgb(0.1, 0.1, 0.1), Texture::Scalar(0.5), 1.0),
        FURNITURE,
        lamp + Vec3::new(0.0, 0.7, 0.0),
        Vec3::new(0.025, 0.7, 0.025),
        0.0,
    );
    b.part(
        MaterialDesc::Emitter {
            name: "bulb".into(),
            radiance: [120.0, 90.0, 50.0],
            // A closed sphere: its inside is never lit either way.
            one_sided: false,
        },
        LIGHT,
        |p, t| icosphere(p, t, lamp + Vec3::new(0.0, 1.48, 0.0), 0.07, 2),
    );
    b.obstacles.push(Obstacle {
        min: lamp + Vec3::new(-0.1, 1.38, -0.1),
        max: lamp + Vec3::new(0.1, 1.58, 0.1),
    });
    b.emitters.push(lamp + Vec3::new(0.0, 1.48, 0.0));
}

/// The room's furniture and decor: a sofa, a table, a glossy box, a metal sphere and a mirror.
fn room_objects(b: &mut Builder) {
    // Furniture.
    add_box(
        b,
        principled("sofa", rgb(0.55, 0.2, 0.15), Texture::Scalar(1.0), 0.0),
        FURNITURE,
        Vec3::new(0.4, 0.3, 1.5),
        Vec3::new(1.0, 0.3, 0.4),
        0.0,
    );
    add_box(
        b,
        principled("table", rgb(0.75, 0.72, 0.68), Texture::Scalar(0.6), 0.0),
        FURNITURE,
        Vec3::new(0.6, 0.35, 0.0),
        Vec3::new(0.6, 0.35, 0.4),
        0.15,
    );
    add_box(
        b,
        principled(
            "glossy_box",
            rgb(0.1, 0.28, 0.62),
            Texture::Scalar(0.15),
            0.0,
        ),
        DECOR,
        Vec3::new(-1.2, 0.3, -0.6),
        Vec3::new(0.3, 0.3, 0.3),
        0.5,
    );
    let sphere_c = Vec3::new(1.7, 0.4, -1.3);
    b.part(
        principled(
            "metal_sphere",
            rgb(0.95, 0.75, 0.45),
            Texture::Scalar(0.4),
            1.0,
        ),
        DECOR,
        |p, t| icosphere(p, t, sphere_c, 0.4, 3),
    );
    b.obstacles.push(Obstacle {
        min: sphere_c - 0.4,
        max: sphere_c + 0.4,
    });
    b.targets.push(sphere_c);
    // Near-mirror panel on the north wall (1 cm off the wall).
    b.part(
        principled("mirror", rgb(0.94, 0.94, 0.95), Texture::Scalar(0.04), 1.0),
        DECOR,
        |p, t| {
            quad(
                p,
                t,
                Vec3::new(-0.9, 0.8, -1.99),
                Vec3::new(1.2, 0., 0.),
                Vec3::new(0., 1.4, 0.),
            )
        },
    );
    b.targets.push(Vec3::new(-0.3, 1.5, -1.99));
}
