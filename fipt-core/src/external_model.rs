//! Reflectance models from outside fipt-core: the trait a crate of its own implements, and the
//! process-wide registry that lets `[model] brdf = "<name>"` find it.
//!
//! A model decides two things, as the built-in ones do ([`crate::reflectance`]): the Smith
//! masking G1 of the GGX lobe, and the diffuse factor B = b0 + σ·b1 + σ²·b2 (f_d = kd/π·B) as
//! three functions of the directions. Everything else (the metallic workflow, GGX's D with
//! α = σ², Schlick's Fresnel, the factorised image) is shared, which is what keeps the image
//! linear in kd and ks at a fixed σ and lets the bake, the search and the training take any
//! model unchanged.
//!
//! The built-in models stay variants of the closed enum, dispatched by a `match` per ray; an
//! external model is the variant [`crate::reflectance::ReflectanceModel::External`], one
//! virtual call per evaluation (its cost against the enum is measured by `fipt bench --suite
//! bake`: the `principled` model through the enum and through this trait).
use std::sync::RwLock;

/// The formulas of a reflectance model defined outside fipt-core.
///
/// Contract (registration checks it at a spread of arguments and refuses a model that breaks
/// it; the BRDF ladder, `fipt_shading::brdf::ladder::check` on
/// `fipt_shading::brdf::MicrofacetBrdf::with_model`, tests the BRDF it makes: reciprocity,
/// sampling, energy, extremes):
/// * [`g1`](Self::g1) is in [0, 1], 1 at `cos` = 1, finite at `cos` → 0, for σ in [0.02, 1];
/// * [`diffuse_basis`](Self::diffuse_basis) is symmetric in (`cos_o`, `cos_i`) (reciprocity)
///   and finite for cosines in (0, 1];
/// * [`diffuse_depends_on_roughness`](Self::diffuse_depends_on_roughness) is `false` only if
///   b1 = b2 = 0 everywhere (then the shadings omit the σ terms of the diffuse part).
pub trait ReflectanceFormulas: Send + Sync + 'static {
    /// The config name (`[model] brdf`), e.g. `oren-nayar`; not a built-in model's name.
    fn name(&self) -> &'static str;
    /// One line for help texts.
    fn description(&self) -> &'static str;
    /// Whether b1 or b2 of [`diffuse_basis`](Self::diffuse_basis) is ever non-zero.
    fn diffuse_depends_on_roughness(&self) -> bool;
    /// Smith masking G1 of one direction at cosine `cos` (> 0) to the normal, roughness σ.
    fn g1(&self, cos: f32, sigma: f32) -> f32;
    /// [`g1`](Self::g1) at every roughness of `sigmas` into `out` (the same length): one call
    /// per sample for all the bake's levels instead of one each. Override only to vectorise.
    #[inline]
    fn g1_each(&self, cos: f32, sigmas: &[f32], out: &mut [f32]) {
        for (o, &s) in out.iter_mut().zip(sigmas) {
            *o = self.g1(cos, s);
        }
    }
    /// (b0, b1, b2) of the diffuse factor B = b0 + σ·b1 + σ²·b2; `cos_o`, `cos_i` are the
    /// cosines to the normal (> 0) and `io` = ωi·ωo.
    fn diffuse_basis(&self, cos_o: f32, cos_i: f32, io: f32) -> [f32; 3];
}

/// A registered external model: a `'static` reference (so the enum stays `Copy`) and the
/// fingerprint of its formulas ([`fingerprint`]). Made by the registry only; two are equal when
/// their names are (the registry keeps names unique).
#[derive(Clone, Copy)]
pub struct ExternalModel {
    formulas: &'static dyn ReflectanceFormulas,
    fingerprint: u32,
}

impl ExternalModel {
    /// The model's formulas.
    #[inline]
    pub fn formulas(self) -> &'static dyn ReflectanceFormulas {
        self.formulas
    }
    /// The fingerprint of its formulas: stored bakes and refinements are keyed by it, so
    /// changing a formula redoes them.
    pub fn fingerprint(self) -> u32 {
        self.fingerprint
    }
}

/// A hash (FNV-1a) of the model's values at fixed arguments: G1 and the diffuse basis at a
/// spread of cosines and roughness values.
pub fn fingerprint(m: &dyn ReflectanceFormulas) -> u32 {
    let mut h: u32 = 0x811c_9dc5;
    let mut eat = |x: f32| {
        for b in x.to_bits().to_le_bytes() {
            h = (h ^ b as u32).wrapping_mul(0x0100_0193);
        }
    };
    eat(m.diffuse_depends_on_roughness() as u32 as f32);
    for cos in [0.05f32, 0.3, 0.7, 1.0] {
        for sigma in [0.02f32, 0.3, 1.0] {
            eat(m.g1(cos, sigma));
        }
        for (ci, io) in [(0.2f32, -0.5f32), (0.6, 0.4), (0.9, 0.8)] {
            m.diffuse_basis(cos, ci, io).into_iter().for_each(&mut eat);
        }
    }
    h
}

/// Refuses formulas that break the contract at a spread of arguments: G1 outside [0, 1] or not
/// 1 at normal incidence, a non-finite or non-reciprocal basis, or b1, b2 ≠ 0 for a model that
/// says its diffuse lobe does not depend on σ.
fn check_contract(m: &dyn ReflectanceFormulas) -> Result<(), String> {
    let name = m.name();
    let cosines = [1e-3f32, 0.05, 0.3, 0.7, 1.0];
    for sigma in [0.02f32, 0.3, 1.0] {
        for cos in cosines {
            let g = m.g1(cos, sigma);
            if !(0.0..=1.0).contains(&g) {
                return Err(format!(
                    "reflectance model `{name}`: g1({cos}, σ = {sigma}) = {g}, outside [0, 1]"
                ));
            }
        }
        let g = m.g1(1.0, sigma);
        if (g - 1.0).abs() > 1e-4 {
            return Err(format!(
                "reflectance model `{name}`: g1(1, σ = {sigma}) = {g}, not 1 at normal incidence"
            ));
        }
    }
    for co in cosines {
        for ci in cosines {
            for io in [-0.9f32, 0.0, 0.5] {
                let (b, r) = (m.diffuse_basis(co, ci, io), m.diffuse_basis(ci, co, io));
                let apart = b
                    .iter()
                    .zip(&r)
                    .any(|(x, y)| (x - y).abs() > 1e-5 * (1.0 + x.abs()));
                if b.iter().any(|v| !v.is_finite()) || apart {
                    return Err(format!("reflectance model `{name}`: diffuse_basis({co}, {ci}, {io}) = {b:?} is not finite or not reciprocal ({r:?} swapped)"));
                }
                if !m.diffuse_depends_on_roughness() && (b[1] != 0.0 || b[2] != 0.0) {
                    return Err(format!("reflectance model `{name}`: diffuse_depends_on_roughness() is false but b1, b2 = {}, {} at ({co}, {ci}, {io})", b[1], b[2]));
                }
            }
        }
    }
    Ok(())
}

impl std::fmt::Debug for ExternalModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "ExternalModel({}#{:08x})",
            self.formulas.name(),
            self.fingerprint
        )
    }
}

impl PartialEq for ExternalModel {
    fn eq(&self, other: &Self) -> bool {
        self.formulas.name() == other.formulas.name()
    }
}

impl Eq for ExternalModel {}

impl std::hash::Hash for ExternalModel {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.formulas.name().hash(state)
    }
}

static REGISTRY: RwLock<Vec<ExternalModel>> = RwLock::new(Vec::new());

/// Adds `model` to the process's registry after checking its contract; registering the same
/// name with the same formulas (the same [`fingerprint`]) again is a no-op. Refuses a name
/// registered with other formulas, or listed in `reserved` (the built-ins).
pub(crate) fn register(
    model: &'static dyn ReflectanceFormulas,
    reserved: &[&str],
) -> Result<ExternalModel, String> {
    let name = model.name();
    let valid = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' || c == '_');
    if !valid {
        return Err(format!(
            "reflectance model name `{name}`: use lower-case letters, digits, `-` and `_`"
        ));
    }
    if reserved.contains(&name) {
        return Err(format!(
            "reflectance model `{name}` is built in; give the external model another name"
        ));
    }
    check_contract(model)?;
    let fp = fingerprint(model);
    let mut reg = REGISTRY.write().unwrap_or_else(|e| e.into_inner());
    if let Some(m) = reg.iter().find(|m| m.formulas.name() == name) {
        return if m.fingerprint == fp {
            Ok(*m)
        } else {
            Err(format!(
                "reflectance model `{name}` is already registered with other formulas"
            ))
        };
    }
    let m = ExternalModel {
        formulas: model,
        fingerprint: fp,
    };
    reg.push(m);
    Ok(m)
}

/// The registered external models, in registration order.
pub fn registered() -> Vec<ExternalModel> {
    REGISTRY.read().unwrap_or_else(|e| e.into_inner()).clone()
}
