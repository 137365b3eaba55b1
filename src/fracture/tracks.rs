//! The initial cracks and crack tips of the models that break particles
//! (continuum damage, the eigen models): a body's `cracks` become broken
//! particles, and a body with a crack origin has its crack tip measured
//! ([`CrackTracks::tips`]). In 2D a crack is a polyline, in 3D a flat
//! polygon (`Scene::cracks`); the tracking is the same in both.

use crate::diagnostics::crack::{CrackTip, TipTracker};
use crate::diagnostics::fragments::{FragmentFinder, NONE};
use crate::particles::Particles;
use crate::scene::Scene;

/// The bodies whose crack tip is tracked.
#[derive(Debug, Clone)]
pub(crate) struct CrackTracks<const D: usize = 2> {
    tracks: Vec<TrackedCrack<D>>,
}

impl<const D: usize> Default for CrackTracks<D> {
    fn default() -> Self {
        CrackTracks { tracks: Vec::new() }
    }
}

/// A body whose crack tip is tracked.
#[derive(Debug, Clone)]
struct TrackedCrack<const D: usize> {
    body: usize,
    /// Its particles not on an initial crack.
    particles: Vec<u32>,
    /// The same, as a mask over all particles.
    member: Vec<bool>,
    /// Those of them that started within the seed radius of the origin.
    roots: Vec<u32>,
    tracker: TipTracker<D>,
}

impl<const D: usize> CrackTracks<D> {
    /// The particles on the initial cracks of the bodies for which
    /// `breaks(b)` (those within 0.55 particle spacings of a body's crack
    /// polylines or faces), and the trackers of those bodies with a crack origin
    /// (default: the first crack point), rooted at the particles within
    /// `seed_radius` of it. Call with the particles in their final order.
    pub(crate) fn place<const V: usize>(
        scene: &Scene,
        parts: &Particles<D, V>,
        seed_radius: f64,
        breaks: impl Fn(usize) -> bool,
    ) -> (CrackTracks<D>, Vec<usize>) {
        let mut out = (CrackTracks::default(), Vec::new());
        let x = &parts.x;
        for (b, spec) in scene.file.bodies.iter().enumerate() {
            if !breaks(b) {
                continue;
            }
            let spacing = scene.particle_spacing(b);
            let mut particles = Vec::new();
            for p in (0..parts.len()).filter(|&p| parts.body[p] as usize == b) {
                if scene.cracks[b].iter().any(|c| c.holds(&x[p], spacing)) {
                    out.1.push(p);
                } else {
                    particles.push(p as u32);
                }
            }
            if let Some(o) = spec
                .crack_origin
                .or_else(|| spec.cracks.first().and_then(|c| c.points.first().copied()))
            {
                let mut member = vec![false; parts.len()];
                particles.iter().for_each(|&p| member[p as usize] = true);
                let r2 = seed_radius * seed_radius;
                let o: [f64; D] = o.get::<D>();
                let roots: Vec<u32> = particles
                    .iter()
                    .copied()
                    .filter(|&p| {
                        let x = x[p as usize];
                        let d = crate::tensor::sub(x, o);
                        crate::tensor::dot(d, d) < r2
                    })
                    .collect();
                out.0.tracks.push(TrackedCrack {
                    body: b,
                    particles,
                    member,
                    roots,
                    tracker: TipTracker::new(o),
                });
            }
        }
        out
    }

    /// Bodies with a crack tip.
    pub(crate) fn bodies(&self) -> Vec<usize> {
        self.tracks.iter().map(|t| t.body).collect()
    }

    /// The trackers' state (what a checkpoint keeps).
    pub(crate) fn trackers(&self) -> Vec<TipTracker<D>> {
        self.tracks.iter().map(|t| t.tracker).collect()
    }

    /// Takes up the trackers' state [`Self::trackers`] gave.
    pub(crate) fn restore(&mut self, trackers: Vec<TipTracker<D>>) -> Result<(), String> {
        if trackers.len() != self.tracks.len() {
            return Err(format!(
                "{} tracked cracks in the checkpoint, {} in the scene",
                trackers.len(),
                self.tracks.len()
            ));
        }
        for (t, tracker) in self.tracks.iter_mut().zip(trackers) {
            t.tracker = tracker;
        }
        Ok(())
    }

    /// The crack tips at `time`. A body's crack is the set of its
    /// `broken` particles (not on an initial crack) connected, through
    /// broken particles at most 1.5 spacings apart, to one of the
    /// particles that started near the crack origin (material points, so
    /// the crack's root is found however far the body has moved): the
    /// crack that grows from the origin, not damage elsewhere (at an
    /// impact face, say). Its tip is its particle farthest from the
    /// origin.
    pub(crate) fn tips<const V: usize>(
        &mut self,
        finder: &mut FragmentFinder,
        spacing: &[f64],
        parts: &Particles<D, V>,
        time: f64,
        broken: impl Fn(usize) -> bool + Sync,
    ) -> Vec<CrackTip<D>> {
        self.tracks
            .iter_mut()
            .map(|t| {
                let found = finder.find(
                    &parts.x,
                    &parts.v,
                    &parts.mass,
                    &parts.vol,
                    spacing,
                    &parts.body,
                    |p| t.member[p] && broken(p),
                );
                let mut seeds: Vec<u32> = t
                    .roots
                    .iter()
                    .map(|&p| found.label[p as usize])
                    .filter(|&l| l != NONE)
                    .collect();
                seeds.sort_unstable();
                seeds.dedup();
                t.tracker.measure(
                    &parts.x,
                    &t.particles,
                    |p| seeds.binary_search(&found.label[p]).is_ok(),
                    time,
                )
            })
            .collect()
    }
}
