//! Fracture models. Each lives in its own module and plugs into the
//! explicit step through the plan; a scene that asks for none runs none.

pub mod damage;
pub mod dfg;
pub mod model;
pub mod phase_field;
