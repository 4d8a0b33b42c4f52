//! The shadow cache of occlusion queries (Haines & Greenberg 1986): the primitives that blocked a
//! thread's latest shadow rays, tested before any traversal. A primitive that blocks a segment
//! proves it blocked, so the answer is exact whatever the cache holds; only the time differs.
//!
//! The most recent occluder is always tested. The [`SLOTS`]` − 1` older ones catch what it
//! misses where a few large primitives block most rays (the walls of a room lit from outside: on
//! `door` they answered 94% of the queries the most recent one missed), but every clear segment
//! pays for their tests, so elsewhere they cost more than they save (on `veach-bidir` they would
//! have answered 4.6%; BDPT, 192×108). So a thread tests them only while they pay. It decides
//! once per [`WINDOW`] queries that the most recent occluder misses, by the share of those
//! blocked by one of the older ones: above 1/[`PAYING_SHARE`] they are tested in the next window.
//! While they are not tested, the thread keeps only the most recent occluder, and every
//! [`IDLE_WINDOWS`]th window it probes: it keeps all of them, testing none, and counts the queries
//! whose blocker, found by traversal, was among the older ones (an index comparison).
//!
//! While the older occluders are tested, all eight are first filtered at once in f32, as a leaf's
//! packet is (`super::packet::LoosePacket`, set from the occluders' primitives when first needed),
//! and only the candidates get the exact f64 test, in the same order as before. The filter never
//! rules out a primitive that blocks, so the answers, and the order in which occluders move, are
//! those of testing every one in f64; only the tests that would have failed are skipped.

use super::packet::{LaneFields, LoosePacket};
use std::cell::RefCell;

/// Occluders kept per thread.
pub const SLOTS: usize = 8;

/// Queries per decision on testing the older occluders.
const WINDOW: u32 = 1024;

/// The older occluders are tested while more than `1/PAYING_SHARE` of the queries that reach them
/// are blocked by one of them. A test costs about 1/30 of an occluded traversal on `veach-bidir`
/// (callgrind); seven of them for one query in eight leaves a margin for scenes whose traversals
/// are cheaper. (Since the older ones are filtered at once, 24 was tried as well: 0.98–1.02×
/// for PT, BDPT, PSSMLT and MMLT on five scenes, geometric mean 0.997×; 8 stays.)
const PAYING_SHARE: u32 = 8;

/// Windows between two probes while the older occluders are not tested.
const IDLE_WINDOWS: u32 = 16;

/// What a thread does with its older occluders in the current window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Older {
    /// Tested, most recent first.
    Tested,
    /// Kept and counted, not tested.
    Probed,
    /// Neither; this many windows until the next probe.
    Idle(u32),
}

/// One thread's occluders and the running count that decides on testing the older ones.
#[derive(Clone, Debug)]
pub struct RecentOccluders {
    /// Primitive indices, most recent first; `u32::MAX` marks an empty slot.
    slots: [u32; SLOTS],
    /// The packet lane that holds each slot's primitive (moved with the slot).
    lanes: [u8; SLOTS],
    /// The BVH whose primitives the lanes in `fresh` hold.
    owner: u32,
    /// The lanes (a bit each) that hold their slot's primitive of `owner`; the others are set
    /// before the next filtering.
    fresh: u32,
    /// The occluders' f32 copies, for filtering all of them at once.
    packet: LoosePacket,
    older: Older,
    /// Queries the most recent occluder missed, in this window.
    queries: u32,
    /// Of those, queries blocked by one of the older occluders (tested or probed).
    older_blocked: u32,
}

impl RecentOccluders {
    /// No occluders yet; the first window probes.
    pub const fn new() -> Self {
        Self {
            slots: [u32::MAX; SLOTS],
            lanes: [0, 1, 2, 3, 4, 5, 6, 7],
            owner: u32::MAX,
            fresh: 0,
            packet: LoosePacket::new(),
            older: Older::Probed,
            queries: 0,
            older_blocked: 0,
        }
    }

    /// Whether a kept occluder blocks the query; `blocks(index)` tests primitive `index` (`None`:
    /// no such primitive, which ends the search). On `false` the caller traverses the BVH and
    /// reports what it found with [`RecentOccluders::traversed`].
    ///
    /// While the older occluders are tested, `filter` first gives the packet lanes that may
    /// block (a conservative f32 test of all eight at once) for the BVH `bvh`, whose primitive
    /// `index` has the lane contents `fields(index)` (`None`: no such primitive), and a slot
    /// whose lane it rules out is not tested in f64. (Filtering only after the most recent
    /// occluder's f64 test missed was measured too: 0.96–1.00× on `door`, the same elsewhere.)
    /// Otherwise every slot asked about is tested in f64.
    #[inline]
    pub fn blocked(
        &mut self,
        bvh: u32,
        filter: impl FnOnce(&LoosePacket) -> u32,
        fields: impl Fn(u32) -> Option<LaneFields>,
        blocks: impl Fn(u32) -> Option<bool>,
    ) -> bool {
        let may = if self.older == Older::Tested {
            self.may_block(bvh, filter, fields)
        } else {
            u32::MAX
        };
        let first = if may & 1 != 0 {
            blocks(self.slots[0])
        } else {
            Some(false)
        };
        match first {
            Some(true) => return true,
            Some(false) => {}
            None => return false,
        }
        self.queries += 1;
        let found = self.older == Older::Tested && self.older_block(may, blocks);
        if self.queries >= WINDOW {
            self.decide();
        }
        found
    }

    /// The slots (a bit each) whose occluder may block: those whose lane the filter keeps, and
    /// those whose lane holds no primitive of `bvh` (empty slots, indices beyond its
    /// primitives), which the f64 test answers as before. Lanes not yet set for `bvh` are set
    /// first.
    #[inline(never)]
    fn may_block(
        &mut self,
        bvh: u32,
        filter: impl FnOnce(&LoosePacket) -> u32,
        fields: impl Fn(u32) -> Option<LaneFields>,
    ) -> u32 {
        if self.owner != bvh {
            self.owner = bvh;
            self.fresh = 0;
        }
        if self.fresh != (1 << SLOTS) - 1 {
            for k in 0..SLOTS {
                let lane = usize::from(self.lanes[k]);
                if self.fresh >> lane & 1 == 0
                    && let Some(f) = fields(self.slots[k])
                {
                    self.packet.set(lane, &f);
                    self.fresh |= 1 << lane;
                }
            }
        }
        // A lane not fresh (an empty slot, an index beyond the BVH's primitives) always may.
        let kept = filter(&self.packet) | !self.fresh;
        let mut may = 0;
        for k in 0..SLOTS {
            may |= (kept >> self.lanes[k] & 1) << k;
        }
        may
    }

    /// Whether one of the older occluders blocks the query (moved to the front if so); slots
    /// not in `may` are known not to.
    #[inline(never)]
    fn older_block(&mut self, may: u32, blocks: impl Fn(u32) -> Option<bool>) -> bool {
        for k in 1..SLOTS {
            if may >> k & 1 == 0 {
                continue;
            }
            match blocks(self.slots[k]) {
                Some(true) => {
                    self.bring_forward(k);
                    self.older_blocked += 1;
                    return true;
                }
                Some(false) => {}
                None => break,
            }
        }
        false
    }

    /// Traversal answered a query [`RecentOccluders::blocked`] could not: `blocker` is the
    /// primitive it found, if any, which becomes the most recent occluder.
    #[inline]
    pub fn traversed(&mut self, blocker: Option<u32>) {
        let Some(index) = blocker else {
            return;
        };
        match self.older {
            Older::Idle(_) => self.replace(0, index),
            Older::Tested => self.push(index),
            Older::Probed => self.probe(index),
        }
    }

    /// A probe window's bookkeeping of the blocker traversal found: counted when it was among
    /// the older occluders, and moved or put to the front.
    #[inline(never)]
    fn probe(&mut self, index: u32) {
        match self.slots.iter().position(|&i| i == index) {
            Some(k) => {
                // Kept, untested: it would have answered.
                self.older_blocked += u32::from(k > 0);
                self.bring_forward(k);
            }
            None => self.push(index),
        }
    }

    /// `index` in front, the others back by one (the oldest dropped).
    #[inline]
    fn push(&mut self, index: u32) {
        self.replace(SLOTS - 1, index);
        self.bring_forward(SLOTS - 1);
    }

    /// Slot `k` holds `index` now; its lane is set before it is next filtered.
    #[inline]
    fn replace(&mut self, k: usize, index: u32) {
        self.slots[k] = index;
        self.fresh &= !(1 << self.lanes[k]);
    }

    /// Move the occluder in slot `k` to the front, the ones before it back by one (each with its
    /// lane).
    #[inline]
    fn bring_forward(&mut self, k: usize) {
        let (index, lane) = (self.slots[k], self.lanes[k]);
        for j in (1..=k).rev() {
            self.slots[j] = self.slots[j - 1];
            self.lanes[j] = self.lanes[j - 1];
        }
        self.slots[0] = index;
        self.lanes[0] = lane;
    }

    /// At the end of a window: test the older occluders in the next one if they were tested or
    /// probed and paid in this one, probe them after [`IDLE_WINDOWS`] idle windows.
    #[cold]
    #[inline(never)]
    fn decide(&mut self) {
        let paid = self.older_blocked * PAYING_SHARE > self.queries;
        self.older = match self.older {
            Older::Tested | Older::Probed if paid => Older::Tested,
            Older::Tested | Older::Probed => Older::Idle(IDLE_WINDOWS - 1),
            Older::Idle(0) => Older::Probed,
            Older::Idle(n) => Older::Idle(n - 1),
        };
        self.queries = 0;
        self.older_blocked = 0;
    }

    /// Whether the older occluders are being tested (for tests).
    #[cfg(test)]
    pub fn tests_older(&self) -> bool {
        self.older == Older::Tested
    }

    /// Occluders that test the older ones from the start (for tests).
    #[cfg(test)]
    pub fn testing_older() -> Self {
        Self {
            older: Older::Tested,
            ..Self::new()
        }
    }

    /// The kept primitives, most recent first (for tests).
    #[cfg(test)]
    pub fn slots(&self) -> [u32; SLOTS] {
        self.slots
    }
}

thread_local! {
    static OCCLUDERS: RefCell<RecentOccluders> = const { RefCell::new(RecentOccluders::new()) };
}

/// Whether a segment is blocked, by this thread's occluders or else by `traverse`, which returns
/// the blocking primitive it found: [`RecentOccluders::blocked`] (with `bvh`, `filter`, `fields`
/// and `blocks` as it takes them), then `traverse` and [`RecentOccluders::traversed`].
#[inline(always)]
pub fn occluded(
    bvh: u32,
    filter: impl FnOnce(&LoosePacket) -> u32,
    fields: impl Fn(u32) -> Option<LaneFields>,
    blocks: impl Fn(u32) -> Option<bool>,
    traverse: impl FnOnce() -> Option<u32>,
) -> bool {
    OCCLUDERS.with_borrow_mut(|r| {
        if r.blocked(bvh, filter, fields, blocks) {
            return true;
        }
        let blocker = traverse();
        r.traversed(blocker);
        blocker.is_some()
    })
}

/// This thread's occluders, most recent first (for tests).
#[cfg(test)]
pub fn kept() -> [u32; SLOTS] {
    OCCLUDERS.with_borrow(|r| r.slots)
}

#[cfg(test)]
mod tests {
    use super::{IDLE_WINDOWS, Older, RecentOccluders, SLOTS, WINDOW};

    /// Queries against a set of "primitives" given as the indices that block them.
    fn query(r: &mut RecentOccluders, blockers: &[u32]) -> bool {
        let hit = r.blocked(
            0,
            |_| u32::MAX,
            |_| None,
            |i| (i != u32::MAX).then(|| blockers.contains(&i)),
        );
        if !hit {
            r.traversed(blockers.first().copied());
        }
        hit
    }

    /// Where a handful of primitives block every query, the first window (a probe) finds that the
    /// older occluders would pay, and from then on they answer nearly every query; where each
    /// query has a blocker of its own, they are never tested, and only probed once in
    /// [`IDLE_WINDOWS`] windows. The answers are the same either way.
    #[test]
    fn older_occluders_are_tested_only_while_they_pay() {
        let mut r = RecentOccluders::new();
        let mut traversals = 0;
        for q in 0..4 * WINDOW {
            let blocker = q % 5;
            let hit = query(&mut r, &[blocker]);
            traversals += u32::from(!hit);
            if q == WINDOW - 1 {
                assert!(!r.tests_older(), "decided within the first window");
            }
        }
        assert!(r.tests_older());
        assert!(
            traversals < WINDOW + 10,
            "{traversals} traversals: the older occluders did not answer"
        );
        let mut r = RecentOccluders::new();
        let mut probed = 0;
        for q in 0..(2 * IDLE_WINDOWS + 2) * WINDOW {
            assert!(!query(&mut r, &[1_000_000 + q]));
            assert!(!r.tests_older());
            probed += u32::from(r.older == Older::Probed);
        }
        assert!(
            (2 * WINDOW - 2..3 * WINDOW).contains(&probed),
            "{probed} queries in probe windows"
        );
    }

    /// Clear segments never come back blocked, and occluders move to the front when they
    /// answer, keeping at most [`SLOTS`] distinct ones.
    #[test]
    fn occluders_are_kept_most_recent_first() {
        let mut r = RecentOccluders::new();
        assert!(!query(&mut r, &[]));
        for b in 0..SLOTS as u32 + 3 {
            assert!(!query(&mut r, &[b]));
        }
        let expected: Vec<u32> = (3..SLOTS as u32 + 3).rev().collect();
        assert_eq!(r.slots.to_vec(), expected);
        r.older = Older::Tested;
        assert!(query(&mut r, &[5]));
        assert_eq!(r.slots[0], 5);
        assert!(!query(&mut r, &[]), "a clear segment");
        let mut seen = r.slots.to_vec();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), SLOTS, "no occluder kept twice");
    }
}
