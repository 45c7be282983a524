//! Edits of a scene's surfaces for relighting, material editing and object insertion: a
//! [`SurfaceModel`] wrapping another one, with per-triangle emission factors and material
//! edits on its triangles, and triangles appended after them (added lights and objects).
use crate::scene::SurfaceModel;
use fipt_core::color::Rgb;
use fipt_core::emitter::EmitSide;
use fipt_core::materials::SurfacePoint;
use fipt_core::reflectance::{base_color, clamp_roughness, metallic_workflow, ReflectanceModel};
use fipt_geom::Mesh;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Set a value or scale it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Op<T> {
    Set(T),
    Scale(f32),
}

/// A material edit; unset fields keep the surface's value. Albedo is the metallic workflow's
/// base colour (kd = albedo·(1 − m), ks = 0.04·(1 − m) + albedo·m).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceEdit {
    #[serde(default)]
    pub albedo: Option<Op<[f32; 3]>>,
    #[serde(default)]
    pub roughness: Option<Op<f32>>,
    #[serde(default)]
    pub metallic: Option<Op<f32>>,
    #[serde(default)]
    pub emission: Option<Op<[f32; 3]>>,
}

impl SurfaceEdit {
    /// Whether the edit changes nothing: no field given, or each given one scaled by 1.
    pub fn is_empty(&self) -> bool {
        let one3 = |o: &Option<Op<[f32; 3]>>| matches!(o, None | Some(Op::Scale(1.0)));
        let one1 = |o: &Option<Op<f32>>| matches!(o, None | Some(Op::Scale(1.0)));
        one3(&self.albedo) && one3(&self.emission) && one1(&self.roughness) && one1(&self.metallic)
    }

    /// Range checks: set values finite and non-negative, roughness and metallic in [0, 1].
    pub fn check(&self) -> Result<(), String> {
        let most = fipt_core::range::MAX_RADIANCE;
        let ok = |x: &f32| (0.0..=most).contains(x);
        let ok_op3 = |o: &Option<Op<[f32; 3]>>| match o {
            Some(Op::Set(v)) => v.iter().all(ok),
            Some(Op::Scale(k)) => ok(k),
            None => true,
        };
        let ok_op1 = |o: &Option<Op<f32>>| match o {
            Some(Op::Set(v)) => (0.0..=1.0).contains(v),
            Some(Op::Scale(k)) => ok(k),
            None => true,
        };
        if !ok_op3(&self.albedo) {
            return Err(format!(
                "albedo: set values and scales must be in [0, {most:e}]"
            ));
        }
        if matches!(self.albedo, Some(Op::Set(v)) if v.iter().any(|x| *x > 1.0)) {
            return Err("albedo: set values in [0, 1] (a base colour above 1 reflects more light than it receives; a scale's result is capped at 1)".into());
        }
        if !ok_op3(&self.emission) {
            return Err(format!("emission: set values and scales must be in [0, {most:e}] (a larger value overflows the tracer's f32)"));
        }
        if !ok_op1(&self.roughness) || !ok_op1(&self.metallic) {
            return Err("roughness / metallic: set values in [0, 1], scales ≥ 0".into());
        }
        Ok(())
    }

    /// The surface point after the edit (emission included).
    pub fn apply(&self, sp: SurfacePoint) -> SurfacePoint {
        let m0 = sp.metallic.clamp(0.0, 1.0);
        let albedo0 = base_color(sp.kd, sp.ks, m0);
        let op3 = |o: Option<Op<[f32; 3]>>, v: Rgb| match o {
            Some(Op::Set(x)) => Vec3::from(x),
            Some(Op::Scale(k)) => v * k,
            None => v,
        };
        let op1 = |o: Option<Op<f32>>, v: f32| match o {
            Some(Op::Set(x)) => x,
            Some(Op::Scale(k)) => v * k,
            None => v,
        };
        let albedo = op3(self.albedo, albedo0).clamp(Vec3::ZERO, Vec3::ONE);
        let metallic = op1(self.metallic, m0).clamp(0.0, 1.0);
        let (kd, ks) = if self.albedo.is_none() && self.metallic.is_none() {
            (sp.kd, sp.ks)
        } else {
            metallic_workflow(albedo, metallic)
        };
        SurfacePoint {
            kd,
            ks,
            roughness: clamp_roughness(op1(self.roughness, sp.roughness)),
            metallic,
            emission: op3(self.emission, sp.emission),
        }
    }
}

/// What an added triangle is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AddedSurface {
    /// Material and emission (uniform over the added mesh).
    pub surface: SurfacePoint,
    /// Emits from the front (winding) side only.
    pub one_sided: bool,
    /// The part index reported for `IndexMA`-like maps.
    pub part: u32,
}

/// A scene's surfaces with edits and additions.
pub struct EditedSurfaces<S> {
    pub base: S,
    base_triangles: usize,
    /// Factor on the emission of each base triangle (empty: all 1).
    emission_scale: Vec<f32>,
    edits: HashMap<u32, SurfaceEdit>,
    added: Vec<AddedSurface>,
    added_index: Vec<u32>,
}

impl<S: SurfaceModel> EditedSurfaces<S> {
    /// Wraps the surfaces of `mesh`'s triangles; nothing is edited yet.
    pub fn new(base: S, mesh: &Mesh) -> Self {
        EditedSurfaces {
            base,
            base_triangles: mesh.triangles.len(),
            emission_scale: Vec::new(),
            edits: HashMap::new(),
            added: Vec::new(),
            added_index: Vec::new(),
        }
    }

    /// Triangles of the base scene.
    pub fn base_triangles(&self) -> usize {
        self.base_triangles
    }

    /// Multiplies the emission of base triangles `tris` by `k` (0: off; their surfaces stay
    /// as the base model says, which for extracted emitters is black).
    pub fn scale_emission(&mut self, tris: impl IntoIterator<Item = u32>, k: f32) {
        if self.emission_scale.is_empty() {
            self.emission_scale = vec![1.0; self.base_triangles];
        }
        for t in tris {
            if let Some(s) = self.emission_scale.get_mut(t as usize) {
                *s *= k;
            }
        }
    }

    /// Applies `edit` to base triangles `tris` (a later edit of a triangle replaces an earlier).
    pub fn edit(&mut self, tris: impl IntoIterator<Item = u32>, edit: SurfaceEdit) {
        for t in tris {
            if (t as usize) < self.base_triangles {
                self.edits.insert(t, edit);
            }
        }
    }

    /// Appends `add` to `mesh` (the scene's mesh, base triangles first) with surface `what`.
    pub fn add(&mut self, mesh: &mut Mesh, add: &Mesh, what: AddedSurface) {
        let idx = self.added.len() as u32;
        self.added.push(what);
        mesh.append(add);
        self.added_index
            .extend(std::iter::repeat_n(idx, add.triangles.len()));
    }

    fn added(&self, tri: u32) -> Option<&AddedSurface> {
        let k = (tri as usize).checked_sub(self.base_triangles)?;
        self.added.get(*self.added_index.get(k)? as usize)
    }

    fn scale(&self, tri: u32) -> f32 {
        self.emission_scale
            .get(tri as usize)
            .copied()
            .unwrap_or(1.0)
    }
}

impl<S: SurfaceModel> SurfaceModel for EditedSurfaces<S> {
    fn model(&self) -> ReflectanceModel {
        self.base.model()
    }
    fn surface(&self, tri: u32, p: Vec3) -> SurfacePoint {
        if let Some(a) = self.added(tri) {
            return a.surface;
        }
        let sp = self.base.surface(tri, p);
        match self.edits.get(&tri) {
            Some(e) => e.apply(sp),
            None => sp,
        }
    }
    fn prefetch(&self, tri: u32, p: Vec3) {
        if self.added(tri).is_none() {
            self.base.prefetch(tri, p);
        }
    }
    fn emission(&self, tri: u32) -> Rgb {
        if let Some(a) = self.added(tri) {
            return a.surface.emission;
        }
        let le = self.base.emission(tri) * self.scale(tri);
        match self.edits.get(&tri).and_then(|e| e.emission) {
            Some(Op::Set(v)) => Vec3::from(v),
            Some(Op::Scale(k)) => le * k,
            None => le,
        }
    }
    fn part(&self, tri: u32) -> u32 {
        match self.added(tri) {
            Some(a) => a.part,
            None => self.base.part(tri),
        }
    }
    fn emit_side(&self, tri: u32) -> EmitSide {
        match self.added(tri) {
            Some(a) if a.one_sided => EmitSide::Front,
            Some(_) => EmitSide::Both,
            None => self.base.emit_side(tri),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::LambertSurfaces;

    fn quad(z: f32) -> Mesh {
        Mesh::from_triangles(
            vec![
                Vec3::new(0.0, 0.0, z),
                Vec3::new(1.0, 0.0, z),
                Vec3::new(1.0, 1.0, z),
                Vec3::new(0.0, 1.0, z),
            ],
            None,
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn edits_scale_and_additions_address_the_right_triangles() {
        let mut mesh = quad(0.0);
        let base = LambertSurfaces {
            albedo: vec![Vec3::splat(0.5); 2],
            emission: vec![Vec3::ZERO, Vec3::splat(3.0)],
        };
        let mut s = EditedSurfaces::new(base, &mesh);
        s.scale_emission([1], 0.0);
        s.edit(
            [0],
            SurfaceEdit {
                albedo: Some(Op::Scale(0.5)),
                ..Default::default()
            },
        );
        let light = AddedSurface {
            surface: SurfacePoint {
                emission: Vec3::splat(7.0),
                roughness: 1.0,
                ..Default::default()
            },
            one_sided: true,
            part: 99,
        };
        s.add(&mut mesh, &quad(1.0), light);
        assert_eq!(mesh.triangles.len(), 4);
        assert_eq!(s.emission(1), Vec3::ZERO);
        assert_eq!(s.surface(0, Vec3::ZERO).kd, Vec3::splat(0.25));
        assert_eq!(s.surface(1, Vec3::ZERO).kd, Vec3::splat(0.5));
        for t in [2, 3] {
            assert_eq!(s.emission(t), Vec3::splat(7.0));
            assert_eq!(s.emit_side(t), EmitSide::Front);
            assert_eq!(s.part(t), 99);
        }
        assert_eq!(s.emit_side(0), EmitSide::Both);
    }

    #[test]
    fn albedo_and_metallic_edits_follow_the_metallic_workflow() {
        let (kd, ks) = metallic_workflow(Vec3::new(0.8, 0.6, 0.2), 0.25);
        let sp = SurfacePoint {
            kd,
            ks,
            roughness: 0.4,
            metallic: 0.25,
            emission: Vec3::ZERO,
        };
        let gold = SurfaceEdit {
            metallic: Some(Op::Set(1.0)),
            roughness: Some(Op::Scale(0.5)),
            ..Default::default()
        }
        .apply(sp);
        assert!((gold.ks - Vec3::new(0.8, 0.6, 0.2)).length() < 1e-5);
        assert_eq!(gold.kd, Vec3::ZERO);
        assert!((gold.roughness - 0.2).abs() < 1e-6);
        // Roughness is clamped to the model's range.
        let mirror = SurfaceEdit {
            roughness: Some(Op::Set(0.0)),
            ..Default::default()
        };
        assert_eq!(mirror.apply(sp).roughness, 0.02);
        assert!(SurfaceEdit {
            metallic: Some(Op::Set(1.5)),
            ..Default::default()
        }
        .check()
        .is_err());
        let json: SurfaceEdit =
            serde_json::from_str(r#"{"albedo": {"set": [1, 0, 0]}, "roughness": {"scale": 2}}"#)
                .unwrap();
        assert_eq!(json.albedo, Some(Op::Set([1.0, 0.0, 0.0])));
    }
}
