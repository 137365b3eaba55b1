//! Struct-of-arrays particle storage: one array per quantity. Arrays that
//! only some scenes need (small strain, deformation gradient, APIC affine
//! matrix, GIMP half-width) are empty when no particle needs them.

/// All particles of a simulation. Index `p` is the same particle in every
/// array. Particles are stored tile by tile (sorted once when the
/// simulation is built); `id` keeps the seeding order.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Particles {
    /// Stable id: the seeding order (bodies in scene order).
    pub id: Vec<u32>,
    /// Index of the body in the scene.
    pub body: Vec<u16>,
    /// Index into `Scene::materials`.
    pub material: Vec<u16>,
    /// Dense contact-group index (position in `Scene::contact_groups`).
    pub group: Vec<u8>,
    /// Position, m.
    pub x: Vec<[f64; 2]>,
    /// Velocity, m/s.
    pub v: Vec<[f64; 2]>,
    /// Mass, kg (constant).
    pub mass: Vec<f64>,
    /// Current volume (area × thickness), m³.
    pub vol: Vec<f64>,
    /// Initial volume, m³.
    pub vol0: Vec<f64>,
    /// Cauchy stress (xx, yy, xy), Pa. σ_zz is derived for output.
    pub stress: Vec<[f64; 3]>,
    /// Small strain (xx, yy, xy tensor component), for linear elastic
    /// materials; empty if none.
    pub strain: Vec<[f64; 3]>,
    /// Deformation gradient (F11, F12, F21, F22), for neo-Hookean
    /// materials; empty if none.
    pub def_grad: Vec<[f64; 4]>,
    /// APIC affine velocity matrix C (C11, C12, C21, C22), 1/s; empty
    /// unless the transfer is APIC.
    pub affine: Vec<[f64; 4]>,
    /// GIMP particle half-width in cells; empty unless the shape functions
    /// are GIMP.
    pub half_size: Vec<f64>,
    /// Phase field c at the particle (1 intact, 0 broken); empty unless a
    /// body has a phase field.
    pub phase: Vec<f64>,
    /// History field H = max ψ⁺, J/m³; empty unless a body has a phase
    /// field.
    pub history: Vec<f64>,
    /// Scalar damage D in [0, 1] (Homel & Herbold 2017); empty unless a material has a
    /// damage model.
    pub damage: Vec<f64>,
    /// Tensile strength σ_f of the particle, Pa (Weibull-distributed where
    /// asked; ∞ for materials without damage); empty unless damage.
    pub strength: Vec<f64>,
}

impl Particles {
    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
}
