//! Struct-of-arrays particle storage: one array per quantity. Arrays that
//! only some scenes need (small strain, deformation gradient, APIC affine
//! matrix, GIMP half-width) are empty when no particle needs them.
//!
//! `Particles<D, V>` holds particles of `D` = 2 or 3 dimensions; `V` is the
//! Voigt length of a symmetric tensor (3 in 2D, 6 in 3D; see
//! [`crate::tensor`]). The defaults are 2D.

/// All particles of a simulation. Index `p` is the same particle in every
/// array. Particles are stored tile by tile (sorted once when the
/// simulation is built); `id` keeps the seeding order.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(bound(
    serialize = "[f64; D]: serde::Serialize, [f64; V]: serde::Serialize, \
                 [[f64; D]; D]: serde::Serialize",
    deserialize = "[f64; D]: serde::Deserialize<'de>, [f64; V]: serde::Deserialize<'de>, \
                   [[f64; D]; D]: serde::Deserialize<'de>"
))]
pub struct Particles<const D: usize = 2, const V: usize = 3> {
    /// Stable id: the seeding order (bodies in scene order).
    pub id: Vec<u32>,
    /// Index of the body in the scene.
    pub body: Vec<u16>,
    /// Index into `Scene::materials`.
    pub material: Vec<u16>,
    /// Dense contact-group index (position in `Scene::contact_groups`).
    pub group: Vec<u8>,
    /// Position, m.
    pub x: Vec<[f64; D]>,
    /// Velocity, m/s.
    pub v: Vec<[f64; D]>,
    /// Mass, kg (constant).
    pub mass: Vec<f64>,
    /// Current volume (2D: area × thickness), m³.
    pub vol: Vec<f64>,
    /// Initial volume, m³.
    pub vol0: Vec<f64>,
    /// Cauchy stress in Voigt order, Pa (2D: xx, yy, xy, with σ_zz
    /// derived for output; 3D: xx, yy, zz, yz, xz, xy).
    pub stress: Vec<[f64; V]>,
    /// Small strain (tensor components, Voigt order), for linear elastic
    /// materials; empty if none.
    pub strain: Vec<[f64; V]>,
    /// Deformation gradient F (row-major: `def_grad[p][a][b]` = F_ab), for
    /// neo-Hookean materials; empty if none.
    pub def_grad: Vec<[[f64; D]; D]>,
    /// APIC affine velocity matrix C (row-major), 1/s; empty unless the
    /// transfer is APIC.
    pub affine: Vec<[[f64; D]; D]>,
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
    /// Displacement gradient ∂u_a/∂x_b = ∫ L dt (row-major), summed in the
    /// constitutive update with the velocity gradient of the particle's
    /// own velocity field; empty unless the scene has explicit cracks,
    /// whose J integral needs it (the rotation as well as the strain:
    /// Nairn & Aimene, eq. 9).
    pub grad_u: Vec<[[f64; D]; D]>,
    /// The eigen models' state of each point (Molinos et al.): the
    /// softening onset, χ and the stress scale; empty unless a material
    /// has an eigen model.
    pub softening: Vec<Softening>,
    /// Acceleration a_p, m/s², carried from one step's corrector to the
    /// next step's predictor by the Newmark predictor–corrector (Molinos
    /// et al., Algorithm 1); empty unless `stress_update = "newmark"`.
    pub accel: Vec<[f64; D]>,
    /// The step's kept supports (LME only; the `supports` stage fills
    /// them): scratch, not saved in a checkpoint and not compared.
    #[serde(skip)]
    pub supports: crate::grid::SupportCache<D>,
}

impl<const D: usize, const V: usize> Particles<D, V> {
    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Bytes the arrays hold on the heap (capacity × element size, so
    /// growth slack counts): what `cleave bench` reports per particle.
    pub fn heap_bytes(&self) -> usize {
        fn b<T>(v: &Vec<T>) -> usize {
            v.capacity() * std::mem::size_of::<T>()
        }
        b(&self.id)
            + b(&self.body)
            + b(&self.material)
            + b(&self.group)
            + b(&self.x)
            + b(&self.v)
            + b(&self.mass)
            + b(&self.vol)
            + b(&self.vol0)
            + b(&self.stress)
            + b(&self.strain)
            + b(&self.def_grad)
            + b(&self.affine)
            + b(&self.half_size)
            + b(&self.phase)
            + b(&self.history)
            + b(&self.damage)
            + b(&self.strength)
            + b(&self.grad_u)
            + b(&self.softening)
            + b(&self.accel)
            + self.supports.heap_bytes()
    }
}

/// One point's state under the eigen models (Molinos et al.; the law is
/// `fracture::eigen::softening`, which re-exports this type: particle
/// storage sits below the fracture models).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Softening {
    /// Principal strain when softening started (eq. 19's ε_I(x⁰));
    /// `None` while the point is intact.
    pub onset: Option<f64>,
    /// The cohesive opening fraction χ = w/w_c (eq. 20), 0 to 1.
    pub chi: f64,
    /// The stress scale: the point carries (1 − d)σ, 0 to 1.
    pub d: f64,
}
