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
/// Contract (the BRDF ladder, `fipt_shading::brdf::ladder::check`, tests all of it on
/// `fipt_shading::brdf::MicrofacetBrdf::with_model`):
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

/// A registered external model: a `'static` reference, so the enum stays `Copy`. Two are equal
/// when their names are (the registry keeps names unique).
#[derive(Clone, Copy)]
pub struct ExternalModel(pub &'static dyn ReflectanceFormulas);

impl ExternalModel {
    /// The model's formulas.
    #[inline]
    pub fn formulas(self) -> &'static dyn ReflectanceFormulas {
        self.0
    }
}

impl std::fmt::Debug for ExternalModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ExternalModel({})", self.0.name())
    }
}

impl PartialEq for ExternalModel {
    fn eq(&self, other: &Self) -> bool {
        self.0.name() == other.0.name()
    }
}

impl Eq for ExternalModel {}

impl std::hash::Hash for ExternalModel {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.name().hash(state)
    }
}

static REGISTRY: RwLock<Vec<ExternalModel>> = RwLock::new(Vec::new());

/// Adds `model` to the process's registry; registering the same object again is a no-op.
/// Refuses a name already taken by another object or listed in `reserved` (the built-ins).
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
    let mut reg = REGISTRY.write().unwrap_or_else(|e| e.into_inner());
    if let Some(m) = reg.iter().find(|m| m.0.name() == name) {
        return if std::ptr::addr_eq(m.0, model) {
            Ok(*m)
        } else {
            Err(format!(
                "reflectance model `{name}` is already registered by another object"
            ))
        };
    }
    let m = ExternalModel(model);
    reg.push(m);
    Ok(m)
}

/// The registered external models, in registration order.
pub fn registered() -> Vec<ExternalModel> {
    REGISTRY.read().unwrap_or_else(|e| e.into_inner()).clone()
}
