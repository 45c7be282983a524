//! The reflectance models: every formula a model decides, in one place.
//!
//! Both models share the metallic workflow (base colour a, roughness σ, metallic m):
//! kd = a·(1 − m), ks = F0 = [`DIELECTRIC_F0`]·(1 − m) + a·m, GGX with α = σ² and Schlick's
//! Fresnel F = ks + (1 − ks)(1 − ωo·h)⁵. They differ in the diffuse lobe and the masking:
//!
//! | model | diffuse f_d / (kd/π) | Smith masking G1 |
//! |---|---|---|
//! | [`ReflectanceModel::Fipt`] (FIPT, method §2) | 1 (Lambert) | Schlick-GGX, k = (σ+1)²/8 |
//! | [`ReflectanceModel::Principled`] (Mitsuba 3 `principled`, Disney 2015, glTF base) | Burley with retro-reflection (below) | exact GGX, 2 / (1 + √(1 + α² tan²θ)) |
//!
//! Burley's factor, with F_x = (1 − cos θx)⁵ and R = 2σ (h·ωo)² = σ (1 + ωi·ωo), is
//! (1 − F_o/2)(1 − F_i/2) + R (F_o + F_i + F_o F_i (R − 1)): a polynomial of degree 2 in σ,
//! B = b0 + σ b1 + σ² b2 ([`ReflectanceModel::diffuse_basis`]). The factorised image stays
//! linear in kd and ks for a fixed σ:
//!
//! L = kd·(Ld0 + σ·Ld1 + σ²·Ld2) + ks·Ls0(σ) + Ls1(σ)
//!
//! with Ld_k = ∫ Li·b_k·cos θi/π dω (Ld1 = Ld2 = 0 under FIPT) and
//! Ls0/Ls1 = ∫ Li·D·G·{1 − F_c, F_c}/(4 cos θo) dω, F_c = (1 − ωo·h)⁵ ([`image`]).
//!
//! Dielectrics of `principled` use Schlick from F0 = 0.08·specular with specular = 0.5 (the
//! default of Blender and Mitsuba), i.e. 0.04 as in FIPT. (Mitsuba evaluates the exact
//! dielectric Fresnel of η = 1.5 instead, which Schlick approximates within 0.02 below 75°.)
//! The masking is Smith's separable form as in Mitsuba (glTF's viewers use the
//! height-correlated one; the two differ by < 2 % below σ = 0.5).
use crate::color::Rgb;
pub use crate::external_model::{ExternalModel, ReflectanceFormulas};
use glam::Vec3;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::f32::consts::PI;

/// F0 of a dielectric: 0.08·specular with specular = 0.5.
pub const DIELECTRIC_F0: f32 = 0.04;

/// Lowest roughness the parametrisation reaches (σ = 0.02 + 0.98·s).
pub const MIN_ROUGHNESS: f32 = 0.02;

/// The reflectance model of a run (`[model] brdf`): the built-in models, dispatched per ray by a
/// match, and the external ones a crate registers ([`ReflectanceModel::register`]), one virtual
/// call per evaluation. Serialised as its name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ReflectanceModel {
    /// FIPT's model: Lambert + GGX with Schlick-GGX masking.
    #[default]
    Fipt,
    /// The principled / glTF metallic-roughness model: Burley + GGX with Smith masking.
    Principled,
    /// A model from a crate of its own ([`ReflectanceFormulas`]).
    External(ExternalModel),
}

impl ReflectanceModel {
    /// The built-in models.
    pub const ALL: [ReflectanceModel; 2] = [ReflectanceModel::Fipt, ReflectanceModel::Principled];

    /// Makes the external `model` known to this process, so `[model] brdf = "<name>"` (and
    /// `--brdf`) find it; the same object again is a no-op. Refuses a built-in's name, a name
    /// taken by another object, and names that are not lower-case letters, digits, `-`, `_`.
    pub fn register(model: &'static dyn ReflectanceFormulas) -> Result<ReflectanceModel, String> {
        let builtin = ReflectanceModel::ALL.map(|m| m.name());
        crate::external_model::register(model, &builtin).map(ReflectanceModel::External)
    }

    /// The built-in models and the registered external ones, for help texts and lookups.
    pub fn known() -> Vec<ReflectanceModel> {
        let external = crate::external_model::registered().into_iter();
        ReflectanceModel::ALL
            .into_iter()
            .chain(external.map(ReflectanceModel::External))
            .collect()
    }

    /// The config name (`fipt`, `principled`, or the external model's).
    pub fn name(self) -> &'static str {
        match self {
            ReflectanceModel::Fipt => "fipt",
            ReflectanceModel::Principled => "principled",
            ReflectanceModel::External(m) => m.formulas().name(),
        }
    }

    /// A component's name for this model: `base` under FIPT's model (the method's), else
    /// `base/<model>` (`fipt-slf/principled`); interned, so a component can return `&str`.
    pub fn component_name(self, base: &'static str) -> &'static str {
        use std::collections::HashMap;
        use std::sync::Mutex;
        type Names = Mutex<HashMap<(&'static str, &'static str), &'static str>>;
        static NAMES: std::sync::OnceLock<Names> = std::sync::OnceLock::new();
        if self == ReflectanceModel::Fipt {
            return base;
        }
        // An external model's stored shadings are keyed by its formulas too.
        let tag = match self {
            ReflectanceModel::External(m) => format!("{}#{:08x}", self.name(), m.fingerprint()),
            _ => self.name().to_string(),
        };
        let mut names = NAMES
            .get_or_init(Default::default)
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        names
            .entry((base, self.name()))
            .or_insert_with(|| Box::leak(format!("{base}/{tag}").into_boxed_str()))
    }

    /// Whether the diffuse lobe depends on σ (then shadings carry Ld1 and Ld2).
    #[inline]
    pub fn diffuse_depends_on_roughness(self) -> bool {
        match self {
            ReflectanceModel::Fipt => false,
            ReflectanceModel::Principled => true,
            ReflectanceModel::External(m) => m.formulas().diffuse_depends_on_roughness(),
        }
    }

    /// Smith masking G1 for one direction at cosine `cos` (> 0) and roughness σ.
    #[inline]
    pub fn g1(self, cos: f32, sigma: f32) -> f32 {
        match self {
            ReflectanceModel::Fipt => {
                let k = (sigma + 1.0) * (sigma + 1.0) / 8.0;
                cos / (cos * (1.0 - k) + k)
            }
            ReflectanceModel::Principled => {
                let a2 = sigma * sigma * sigma * sigma;
                let c2 = cos * cos;
                if c2 >= 1.0 {
                    return 1.0;
                }
                // α² tan²θ = α² (1 − c²)/c²; written so that c → 0 gives 0, not NaN.
                let t = a2 * (1.0 - c2);
                2.0 * cos / (cos + (c2 + t).sqrt())
            }
            ReflectanceModel::External(m) => m.formulas().g1(cos, sigma),
        }
    }

    /// G1 at cosine `cos` for every roughness of `sigmas` (one dispatch, a loop the compiler can
    /// vectorise: the bake evaluates it per sample for all levels).
    #[inline]
    pub fn g1_levels<const N: usize>(self, cos: f32, sigmas: &[f32; N]) -> [f32; N] {
        match self {
            ReflectanceModel::Fipt => std::array::from_fn(|l| {
                let k = (sigmas[l] + 1.0) * (sigmas[l] + 1.0) / 8.0;
                cos / (cos * (1.0 - k) + k)
            }),
            ReflectanceModel::Principled => {
                std::array::from_fn(|l| ReflectanceModel::Principled.g1(cos, sigmas[l]))
            }
            ReflectanceModel::External(m) => {
                let mut out = [0.0; N];
                m.formulas().g1_each(cos, sigmas, &mut out);
                out
            }
        }
    }

    /// The coefficients (b0, b1, b2) of the diffuse factor B = b0 + σ·b1 + σ²·b2, where
    /// f_d = kd/π·B; `cos_o`, `cos_i` are the cosines to the normal, `io` = ωi·ωo.
    #[inline]
    pub fn diffuse_basis(self, cos_o: f32, cos_i: f32, io: f32) -> [f32; 3] {
        match self {
            ReflectanceModel::Fipt => [1.0, 0.0, 0.0],
            ReflectanceModel::Principled => {
                let (fo, fi) = (schlick_weight(cos_o), schlick_weight(cos_i));
                let r = 1.0 + io; // R / σ = 2 (h·ωo)²
                [
                    (1.0 - 0.5 * fo) * (1.0 - 0.5 * fi),
                    r * (fo + fi - fo * fi),
                    r * r * fo * fi,
                ]
            }
            ReflectanceModel::External(m) => m.formulas().diffuse_basis(cos_o, cos_i, io),
        }
    }
}

impl std::fmt::Display for ReflectanceModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for ReflectanceModel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let known = ReflectanceModel::known();
        known
            .iter()
            .copied()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = known.iter().map(|m| m.name()).collect();
                format!(
                    "unknown reflectance model `{s}` (this binary has: {})",
                    names.join(", ")
                )
            })
    }
}

impl Serialize for ReflectanceModel {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for ReflectanceModel {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

/// The built-in `principled` model through the external path ([`ReflectanceFormulas`]),
/// registered as `principled-via-trait`: the same formulas, so its results are the enum's to
/// the bit, and its speed against the enum's is the cost of the trait (`fipt bench --suite
/// bake`). Also a template for a model of one's own.
pub struct PrincipledViaTrait;

impl ReflectanceFormulas for PrincipledViaTrait {
    fn name(&self) -> &'static str {
        "principled-via-trait"
    }
    fn description(&self) -> &'static str {
        "the built-in principled model called through the external-model trait (for measuring its cost)"
    }
    fn diffuse_depends_on_roughness(&self) -> bool {
        true
    }
    #[inline]
    fn g1(&self, cos: f32, sigma: f32) -> f32 {
        ReflectanceModel::Principled.g1(cos, sigma)
    }
    #[inline]
    fn diffuse_basis(&self, cos_o: f32, cos_i: f32, io: f32) -> [f32; 3] {
        ReflectanceModel::Principled.diffuse_basis(cos_o, cos_i, io)
    }
}

/// The metallic workflow: (kd, ks) of base colour `a` and metallic `m`.
#[inline]
pub fn metallic_workflow(a: Rgb, m: f32) -> (Rgb, Rgb) {
    (
        a * (1.0 - m),
        Vec3::splat(DIELECTRIC_F0 * (1.0 - m)) + a * m,
    )
}

/// The derivatives of [`metallic_workflow`]: (∂kd/∂a, ∂ks/∂a) per channel of `a` (each
/// channel depends only on its own), and (∂kd/∂m, ∂ks/∂m).
#[inline]
pub fn metallic_workflow_derivatives(a: Rgb, m: f32) -> ((f32, f32), (Rgb, Rgb)) {
    ((1.0 - m, m), (-a, a - Vec3::splat(DIELECTRIC_F0)))
}

/// One channel of [`metallic_workflow`]: (kd, ks) of base colour `a` and metallic `m` (the
/// fused loss's per-channel form; the same expression, the same bits).
#[inline]
pub fn metallic_workflow_channel(a: f32, m: f32) -> (f32, f32) {
    (a * (1.0 - m), DIELECTRIC_F0 * (1.0 - m) + a * m)
}

/// One channel of [`metallic_workflow_derivatives`]: ((∂kd/∂a, ∂ks/∂a), (∂kd/∂m, ∂ks/∂m)).
#[inline]
pub fn metallic_workflow_channel_derivatives(a: f32, m: f32) -> ((f32, f32), (f32, f32)) {
    ((1.0 - m, m), (-a, a - DIELECTRIC_F0))
}

/// The factorised image of the metallic workflow as a linear function of the base colour a at
/// (σ, m), from shadings taken at σ: I = a·b + c with b = (1 − m)·Ld + m·Ls0 (= ∂I/∂a) and
/// c = 0.04·(1 − m)·Ls0 + Ls1. For one channel (`f32`) or three (`Rgb`).
#[inline]
pub fn image_linear_in_base_color<T>(ld: T, ls0: T, ls1: T, m: f32) -> (T, T)
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    (
        ld * (1.0 - m) + ls0 * m,
        ls0 * (DIELECTRIC_F0 * (1.0 - m)) + ls1,
    )
}

/// The base colour of the metallic workflow back from (kd, ks, m): kd / (1 − m), or ks for a
/// metal (m ≈ 1), where kd carries nothing.
#[inline]
pub fn base_color(kd: Rgb, ks: Rgb, m: f32) -> Rgb {
    let m = m.clamp(0.0, 1.0);
    if m < 1.0 - 1e-4 {
        kd / (1.0 - m)
    } else {
        ks
    }
}

/// σ clamped to the model's range [0.02, 1].
#[inline]
pub fn clamp_roughness(sigma: f32) -> f32 {
    sigma.clamp(MIN_ROUGHNESS, 1.0)
}

/// GGX normal distribution for α at the local half vector `h` (unit, normal = +z).
///
/// Written as α² / (π (α² cos²θh + sin²θh)²) with sin²θh = hx² + hy², which stays accurate
/// for α² near f32's epsilon (σ = 0.02 gives α² = 1.6e-7), where the textbook form
/// cos²θh(α²−1)+1 cancels catastrophically.
#[inline]
pub fn ggx_d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let s2 = h.x * h.x + h.y * h.y;
    let d = a2 * h.z * h.z + s2;
    if d <= 0.0 {
        return 0.0;
    }
    a2 / (PI * d * d)
}

/// Schlick's Fresnel weight (1 − c)⁵.
#[inline]
pub fn schlick_weight(c: f32) -> f32 {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// The diffuse shading at σ and its derivative in σ: Ld0 + σ·Ld1 + σ²·Ld2 (`poly` = [Ld1, Ld2],
/// `None` when the model's diffuse lobe does not depend on σ).
#[inline]
pub fn diffuse_at(ld: Rgb, poly: Option<&[Rgb; 2]>, sigma: f32) -> (Rgb, Rgb) {
    match poly {
        None => (ld, Vec3::ZERO),
        Some([l1, l2]) => (
            ld + *l1 * sigma + *l2 * (sigma * sigma),
            *l1 + *l2 * (2.0 * sigma),
        ),
    }
}

/// The factorised image kd·Ld(σ) + ks·Ls0(σ) + Ls1(σ) from shadings already taken at σ.
#[inline]
pub fn image(kd: Rgb, ks: Rgb, ld: Rgb, ls0: Rgb, ls1: Rgb) -> Rgb {
    kd * ld + ks * ls0 + ls1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The per-channel forms (the fused loss's) give the bits of the colour forms, and the
    /// image's linear form in the base colour is the image of the metallic workflow, with
    /// ∂I/∂a and ∂I/∂m the derivatives' chain.
    #[test]
    fn the_image_model_in_its_three_forms_agrees() {
        let mut rng = crate::rng::Pcg32::new(7, 1);
        for _ in 0..1000 {
            let mut v = || rng.next_f32();
            let (a, m) = (Vec3::new(v(), v(), v()), v());
            let (ld, s0, s1) = (
                Vec3::new(v(), v(), v()) * 5.0,
                Vec3::splat(v()),
                Vec3::splat(v()),
            );
            let (kd, ks) = metallic_workflow(a, m);
            let ((dkd_da, dks_da), (dkd_dm, dks_dm)) = metallic_workflow_derivatives(a, m);
            for c in 0..3 {
                let (kdc, ksc) = metallic_workflow_channel(a[c], m);
                assert_eq!(
                    (kdc.to_bits(), ksc.to_bits()),
                    (kd[c].to_bits(), ks[c].to_bits())
                );
                let ((da0, da1), (dm0, dm1)) = metallic_workflow_channel_derivatives(a[c], m);
                assert_eq!([da0, da1, dm0, dm1], [dkd_da, dks_da, dkd_dm[c], dks_dm[c]]);
                let (b, k) = image_linear_in_base_color(ld[c], s0[c], s1[c], m);
                let (bv, kv) = image_linear_in_base_color(ld, s0, s1, m);
                assert_eq!(
                    (b.to_bits(), k.to_bits()),
                    (bv[c].to_bits(), kv[c].to_bits())
                );
                assert_eq!(b, da0 * ld[c] + da1 * s0[c]);
            }
            let (b, k) = image_linear_in_base_color(ld, s0, s1, m);
            let i = image(kd, ks, ld, s0, s1);
            assert!((a * b + k - i).abs().max_element() < 1e-5 * (1.0 + i.max_element()));
        }
    }

    /// A test model: G1 ≡ 1, a constant diffuse basis, σ-independent by its own account.
    struct Fixed(&'static str, [f32; 3]);

    impl ReflectanceFormulas for Fixed {
        fn name(&self) -> &'static str {
            self.0
        }
        fn description(&self) -> &'static str {
            ""
        }
        fn diffuse_depends_on_roughness(&self) -> bool {
            false
        }
        fn g1(&self, _: f32, _: f32) -> f32 {
            1.0
        }
        fn diffuse_basis(&self, _: f32, _: f32, _: f32) -> [f32; 3] {
            self.1
        }
    }

    /// An external model is found by name, serialised as its name, and computes what its
    /// formulas say; the registry refuses built-in and taken names.
    #[test]
    fn external_models_register_and_dispatch() {
        static VIA: PrincipledViaTrait = PrincipledViaTrait;
        let m = ReflectanceModel::register(&VIA).unwrap();
        assert_eq!(ReflectanceModel::register(&VIA).unwrap(), m, "idempotent");
        static OTHER: Fixed = Fixed("principled-via-trait", [1.0, 0.0, 0.0]);
        assert!(ReflectanceModel::register(&OTHER)
            .unwrap_err()
            .contains("other formulas"));
        static FIPT: Fixed = Fixed("fipt", [1.0, 0.0, 0.0]);
        static BAD: Fixed = Fixed("Oren Nayar", [1.0, 0.0, 0.0]);
        assert!(ReflectanceModel::register(&FIPT)
            .unwrap_err()
            .contains("built in"));
        assert!(ReflectanceModel::register(&BAD).is_err());
        assert_eq!("principled-via-trait".parse::<ReflectanceModel>(), Ok(m));
        assert_eq!(
            serde_json::to_string(&m).unwrap(),
            "\"principled-via-trait\""
        );
        let back: ReflectanceModel = serde_json::from_str("\"principled-via-trait\"").unwrap();
        assert_eq!(back, m);
        assert!("nope"
            .parse::<ReflectanceModel>()
            .unwrap_err()
            .contains("principled-via-trait"));
        assert!(m.diffuse_depends_on_roughness());
        let ReflectanceModel::External(e) = m else {
            panic!("{m:?}")
        };
        assert_eq!(
            m.component_name("fipt-slf"),
            format!("fipt-slf/principled-via-trait#{:08x}", e.fingerprint())
        );
        // The contract is checked at registration.
        static BRIGHT: Fixed = Fixed("bright", [1.0, 0.5, 0.0]);
        let err = ReflectanceModel::register(&BRIGHT).unwrap_err();
        assert!(err.contains("diffuse_depends_on_roughness"), "{err}");
        assert_eq!(
            ReflectanceModel::Fipt.component_name("fipt-slf"),
            "fipt-slf"
        );
        // The same formulas through the trait give the enum's bits.
        let p = ReflectanceModel::Principled;
        let mut rng = crate::rng::Pcg32::new(3, 1);
        for _ in 0..1000 {
            let (co, ci, s) = (rng.next_f32(), rng.next_f32(), rng.next_f32());
            let io = 2.0 * rng.next_f32() - 1.0;
            assert_eq!(m.g1(co, s).to_bits(), p.g1(co, s).to_bits());
            assert_eq!(m.diffuse_basis(co, ci, io), p.diffuse_basis(co, ci, io));
            let l = [0.02, s, 1.0];
            assert_eq!(m.g1_levels(co, &l), p.g1_levels(co, &l));
        }
    }

    /// Burley's factor written out as in the Disney notes, against the basis.
    #[test]
    fn diffuse_basis_is_burley_with_retro_reflection() {
        let dirs = [
            (Vec3::new(0.3, 0.1, 0.95), Vec3::new(-0.5, 0.2, 0.84)),
            (Vec3::new(0.9, 0.0, 0.1), Vec3::new(0.8, 0.3, 0.2)),
            (Vec3::Z, Vec3::new(0.99, 0.0, 0.01)),
        ];
        for (o, i) in dirs {
            let (o, i) = (o.normalize(), i.normalize());
            let h = (o + i).normalize();
            for sigma in [0.02f32, 0.3, 1.0] {
                let (fo, fi) = (schlick_weight(o.z), schlick_weight(i.z));
                let rr = 2.0 * sigma * h.dot(o).powi(2);
                let want =
                    (1.0 - 0.5 * fo) * (1.0 - 0.5 * fi) + rr * (fo + fi + fo * fi * (rr - 1.0));
                let b = ReflectanceModel::Principled.diffuse_basis(o.z, i.z, o.dot(i));
                let got = b[0] + sigma * b[1] + sigma * sigma * b[2];
                assert!((got - want).abs() < 1e-5, "{got} vs {want}");
            }
            assert_eq!(
                ReflectanceModel::Fipt.diffuse_basis(o.z, i.z, o.dot(i)),
                [1.0, 0.0, 0.0]
            );
        }
    }

    /// Exact Smith G1 of GGX: 1 at normal incidence, 0 at grazing, and the closed form
    /// 2/(1 + √(1 + α² tan²θ)) in between; Schlick-GGX is its usual approximation.
    #[test]
    fn masking_limits_and_closed_form() {
        let p = ReflectanceModel::Principled;
        for sigma in [0.02f32, 0.5, 1.0] {
            assert_eq!(p.g1(1.0, sigma), 1.0);
            assert!(p.g1(0.0, sigma).abs() < 1e-6);
            let c = 0.4f32;
            let a = sigma * sigma;
            let tan2 = (1.0 - c * c) / (c * c);
            let want = 2.0 / (1.0 + (1.0 + a * a * tan2).sqrt());
            assert!((p.g1(c, sigma) - want).abs() < 1e-6);
        }
        for m in ReflectanceModel::ALL {
            let s = [0.02, 0.3, 1.0];
            assert_eq!(m.g1_levels(0.4, &s), s.map(|x| m.g1(0.4, x)));
        }
        // FIPT's Schlick-GGX (k = (σ+1)²/8, the remapping for analytic lights) is exact at σ = 1
        // and too dark for smooth surfaces (0.84 instead of 1.0 at σ = 0.02, cos 0.4).
        let f = ReflectanceModel::Fipt;
        assert!((f.g1(0.4, 1.0) - p.g1(0.4, 1.0)).abs() < 1e-4);
        assert!(p.g1(0.4, 0.02) - f.g1(0.4, 0.02) > 0.15);
    }

    #[test]
    fn names_round_trip_and_workflow_limits() {
        for m in ReflectanceModel::ALL {
            assert_eq!(m.name().parse::<ReflectanceModel>().unwrap(), m);
            let j = serde_json::to_string(&m).unwrap();
            assert_eq!(j, format!("\"{}\"", m.name()));
        }
        assert!("pbr"
            .parse::<ReflectanceModel>()
            .unwrap_err()
            .contains("principled"));
        let a = Vec3::new(0.9, 0.5, 0.1);
        assert_eq!(metallic_workflow(a, 0.0), (a, Vec3::splat(0.04)));
        assert_eq!(metallic_workflow(a, 1.0), (Vec3::ZERO, a));
        // The derivatives against central differences of the workflow.
        let (a, m, h) = (Vec3::new(0.7, 0.2, 0.5), 0.3f32, 1e-3f32);
        let ((kd_a, ks_a), (kd_m, ks_m)) = metallic_workflow_derivatives(a, m);
        let (p, q) = (metallic_workflow(a, m + h), metallic_workflow(a, m - h));
        assert!(((p.0 - q.0) / (2.0 * h) - kd_m).abs().max_element() < 1e-3);
        assert!(((p.1 - q.1) / (2.0 * h) - ks_m).abs().max_element() < 1e-3);
        let (p, q) = (metallic_workflow(a + h, m), metallic_workflow(a - h, m));
        assert!(
            ((p.0 - q.0) / (2.0 * h) - Vec3::splat(kd_a))
                .abs()
                .max_element()
                < 1e-3
        );
        assert!(
            ((p.1 - q.1) / (2.0 * h) - Vec3::splat(ks_a))
                .abs()
                .max_element()
                < 1e-3
        );
        let (d, d1) = diffuse_at(Vec3::ONE, Some(&[Vec3::splat(2.0), Vec3::splat(3.0)]), 0.5);
        assert_eq!((d, d1), (Vec3::splat(2.75), Vec3::splat(5.0)));
    }
}
