//! When a batch's rays walk the tree in 8-ray packets and when one at a time.
//!
//! A packet tests a node's children against all its rays at once, one lane per ray (module
//! `packet`), where a single ray tests the node's eight children at once: a packet's visit to a
//! node costs more than one single-ray visit and serves the rays still in it. So packets pay
//! while their rays walk the same nodes: a tile's camera rays, or bounce rays of one octant from
//! neighbouring pixels on a scene of large triangles. They lose where the rays part ways high in
//! the tree, as on a million small triangles, where a packet's visits hold under two rays on
//! average and nearly all its triangle tests serve one.
//!
//! Which holds depends on the scene and on the rays, so it is measured as the rays go. One
//! packet in [`PROBE_EVERY`] walks as a packet whatever was measured and counts how full it ran
//! (rays per node visit) into a [`PacketGauge`]. The others walk as packets while the gauge's
//! average is at least [`MIN_RAYS_PER_VISIT`], and one ray at a time otherwise. The renderer
//! keeps one gauge per thread for its bounce rays, across batches, fading it at each batch so
//! that it follows the scene's depth and content. A packet's hits are its rays' single-ray hits
//! bit for bit, so the choice changes the speed only, never an image.

/// How the rays of a batch ([`super::SceneAccel::intersect_batch_using`]) are traced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacketUse {
    /// Eight rays at a time wherever they share a direction octant.
    Always,
    /// One ray at a time.
    Never,
    /// As packets where they run full enough to pay, by a [`PacketGauge`]'s measure (module
    /// docs): the renderer's choice for bounce rays.
    WherePaying,
}

/// One packet in this many walks as a packet, and counts how full it ran, whatever the gauge
/// says: the first of every batch, and one in eight after it.
pub(super) const PROBE_EVERY: usize = 8;

/// The fewest rays per node visit, on average, at which packets walk (BENCHMARKS.md, "Packets
/// or single rays"). Measured on the peer scenes and the default scene:
/// - The 1M-triangle spheres' bounce batches run at 1.8 (median 1.7), and there single rays
///   shade 12 % faster.
/// - The helmet's run at 3.7 and the default scene's at 3.0, and there packets shade 19 % and
///   7 % faster.
/// - Camera batches run at 3.2 to 5.0.
///
/// At 2.3, a thread's gauge of bounce packets sends 69 % of the spheres' bounce packets one ray
/// at a time and 0.1 % of the helmet's and the default scene's.
pub(super) const MIN_RAYS_PER_VISIT: f32 = 2.3;

/// How one packet of a batch walks the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Walk {
    /// As a packet, counting how full it runs into the [`PacketGauge`] in use.
    Probe,
    /// As a packet.
    Packet,
    /// One ray at a time.
    Single,
}

/// How full the probe packets have run lately: kept by the caller from one batch of a kind to
/// the next ([`super::SceneAccel::intersect_batch_gauged`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct PacketGauge {
    /// Interior nodes the probes visited.
    visits: u64,
    /// Rays in the packet at each of those visits, summed.
    rays: u64,
}

impl PacketGauge {
    /// Halves what was counted, at the start of a batch: the measure follows the latest
    /// batches (a path's later bounces part ways more than its first).
    pub(super) fn fade(&mut self) {
        self.visits /= 2;
        self.rays /= 2;
    }

    /// Adds a packet's count of node visits and the rays it held at them.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) fn add(&mut self, visits: u32, rays: u32) {
        self.visits += u64::from(visits);
        self.rays += u64::from(rays);
    }

    /// How packet `index` of its batch walks under `policy`.
    pub(super) fn walk(&self, policy: PacketUse, index: usize) -> Walk {
        match policy {
            PacketUse::Always => Walk::Packet,
            PacketUse::Never => Walk::Single,
            PacketUse::WherePaying if index.is_multiple_of(PROBE_EVERY) => Walk::Probe,
            PacketUse::WherePaying if self.pays() => Walk::Packet,
            PacketUse::WherePaying => Walk::Single,
        }
    }

    /// Whether the packets so far ran full enough to pay (see [`MIN_RAYS_PER_VISIT`]).
    fn pays(&self) -> bool {
        self.rays as f32 >= MIN_RAYS_PER_VISIT * self.visits as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One packet in PROBE_EVERY walks as a probe whatever was measured; the others by the
    /// average, at the threshold exactly included; fading keeps the average.
    #[test]
    fn packets_walk_where_they_ran_full_enough() {
        let empty = PacketGauge::default();
        let mut sparse = PacketGauge::default();
        sparse.add(100, (100.0 * MIN_RAYS_PER_VISIT) as u32 - 1);
        let mut full = PacketGauge::default();
        full.add(100, (100.0 * MIN_RAYS_PER_VISIT) as u32);
        for index in [0, PROBE_EVERY, 3 * PROBE_EVERY] {
            assert_eq!(sparse.walk(PacketUse::WherePaying, index), Walk::Probe);
        }
        assert_eq!(sparse.walk(PacketUse::WherePaying, 1), Walk::Single);
        assert_eq!(full.walk(PacketUse::WherePaying, 1), Walk::Packet);
        // Nothing measured yet: nothing against packets.
        assert_eq!(empty.walk(PacketUse::WherePaying, 1), Walk::Packet);
        for index in [0, 1, PROBE_EVERY] {
            assert_eq!(sparse.walk(PacketUse::Always, index), Walk::Packet);
            assert_eq!(full.walk(PacketUse::Never, index), Walk::Single);
        }
        let mut faded = PacketGauge::default();
        faded.add(1000, 1500);
        faded.fade();
        assert_eq!((faded.visits, faded.rays), (500, 750));
        faded.add(100, 800);
        assert_eq!(faded.walk(PacketUse::WherePaying, 1), Walk::Packet);
    }
}
