//! Eigenerosion and eigensoftening (Molinos et al., after Pandolfi &
//! Ortiz and Navas et al.): material points fail when the energy released
//! (eigenerosion) or the mean principal stress (eigensoftening) over their
//! ε-neighbourhood ([`crate::neighbours`]) reaches the material's
//! toughness or strength. Built so far: the softening law
//! ([`softening`]); the stage that evaluates the neighbourhoods and the
//! scene keys are the next slice of issue 34 (docs/eigen.md).

pub mod softening;
