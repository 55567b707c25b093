//! The two kinds of shared-memory access the binning stages make, behind traits so that the
//! same stage function runs on a GPU storage buffer and on the host's atomics.

/// Atomic counters in device memory.
pub trait Counters {
    /// Adds `value` to counter `index` and returns the previous value.
    fn fetch_add(&mut self, index: usize, value: u32) -> u32;
}

/// A buffer written at distinct indices by many invocations.
pub trait Slots<T = u32> {
    fn store(&mut self, index: usize, value: T);
}

#[cfg(target_arch = "spirv")]
impl Counters for [u32] {
    fn fetch_add(&mut self, index: usize, value: u32) -> u32 {
        use spirv_std::memory::{Scope, Semantics};
        // Queue-family scope covers every invocation of the dispatch; device scope would need
        // the VulkanMemoryModelDeviceScope capability for no gain here.
        unsafe { spirv_std::arch::atomic_i_add::<u32, { Scope::QueueFamily as u32 }, { Semantics::NONE.bits() }>(&mut self[index], value) }
    }
}

impl<T: Copy> Slots<T> for [T] {
    fn store(&mut self, index: usize, value: T) {
        self[index] = value;
    }
}

/// Lanes of a SIMD group that read together what they all need: a triangle record or a run of
/// bin entries, the same words in every lane. Each of eight lanes loads one word and the
/// others take it from that lane (subgroup shuffles), so eight words cost one load. A CPU
/// implementation of Vulkan (lavapipe) loads storage memory one lane at a time, each load
/// behind a branch on its lane's mask, so there a word read per lane costs several times the
/// arithmetic around it; on a GPU a shuffle is as cheap as an add.
///
/// On the GPU, every lane of the group must reach each read (the loop around it uniform), and
/// the device's subgroups must hold whole groups of [`LANE_GROUP`] lanes (subgroup size a
/// multiple of 8: the host checks it). The host's twin reads the words itself: the same words,
/// so the same bits.
#[derive(Copy, Clone)]
pub struct Lanes {
    /// Subgroup index of the group's first lane.
    #[cfg(target_arch = "spirv")]
    first: u32,
    /// This lane's position in its group.
    #[cfg(target_arch = "spirv")]
    lane: u32,
}

/// Lanes that read a record together.
pub const LANE_GROUP: u32 = 8;

/// Eight consecutive words of a buffer (`u32`s or `u64`s), read by a group of lanes
/// ([`Lanes::read8`]).
#[derive(Copy, Clone)]
pub struct Words8<W: LaneValue> {
    /// The word this lane loaded, which the others shuffle out...
    #[cfg(target_arch = "spirv")]
    mine: W,
    /// ... from the group that starts at this subgroup index...
    #[cfg(target_arch = "spirv")]
    first: u32,
    /// ... where this lane is this word.
    #[cfg(target_arch = "spirv")]
    lane: u32,
    #[cfg(not(target_arch = "spirv"))]
    words: [W; LANE_GROUP as usize],
}

impl Lanes {
    /// The lanes of the group that holds subgroup lane `subgroup_lane` (the
    /// `SubgroupLocalInvocationId` builtin).
    #[cfg(target_arch = "spirv")]
    #[inline]
    pub fn new(subgroup_lane: u32) -> Lanes {
        Lanes { first: subgroup_lane & !(LANE_GROUP - 1), lane: subgroup_lane & (LANE_GROUP - 1) }
    }

    /// The host's twin: one invocation reads every word itself.
    #[cfg(not(target_arch = "spirv"))]
    #[inline]
    pub fn new() -> Lanes {
        Lanes {}
    }

    /// Words `at..at + 8` of `words`. Words past the end of the buffer read as some word of it
    /// (the last on the GPU, 0 on the host): no record or run uses them. A CPU implementation
    /// of Vulkan pays the same for a 64-bit load as for a 32-bit one, so records are read as
    /// `u64`s: a group reads sixteen 32-bit words with one load per lane.
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    pub fn read8<W: LaneValue>(&self, words: &[W], at: u32) -> Words8<W> {
        let last = words.len() as u32 - 1;
        let k = at + self.lane;
        Words8 { mine: words[(if k < last { k } else { last }) as usize], first: self.first, lane: self.lane }
    }

    #[cfg(not(target_arch = "spirv"))]
    #[inline(always)]
    pub fn read8<W: LaneValue>(&self, words: &[W], at: u32) -> Words8<W> {
        Words8 { words: core::array::from_fn(|k| words.get(at as usize + k).copied().unwrap_or(W::ZERO)) }
    }
}

#[cfg(not(target_arch = "spirv"))]
impl Default for Lanes {
    fn default() -> Self {
        Self::new()
    }
}

impl Lanes {
    /// Whether `p` holds in every lane of the subgroup (so a loop around reads may stop for all
    /// of them at once); on the host, in the one invocation.
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    pub fn all(&self, p: bool) -> bool {
        spirv_std::arch::subgroup_all(p)
    }

    #[cfg(not(target_arch = "spirv"))]
    #[inline(always)]
    pub fn all(&self, p: bool) -> bool {
        p
    }
}

impl<W: LaneValue> Words8<W> {
    /// Word `k < 8`. On the GPU every lane of the group must ask at once (`k` the same in all).
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    pub fn get(&self, k: u32) -> W {
        self.mine.shuffle(self.first + k)
    }

    #[cfg(not(target_arch = "spirv"))]
    #[inline(always)]
    pub fn get(&self, k: u32) -> W {
        self.words[k as usize]
    }

    /// Bit `k` for each word `k < run` that `keep` keeps: on the GPU, each lane tests its own
    /// word and the group's votes make one mask (the same in all its lanes).
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    pub fn select(&self, run: u32, keep: impl Fn(W) -> bool) -> u32 {
        let votes = spirv_std::arch::subgroup_ballot(self.lane < run && keep(self.mine));
        let word = match self.first / 32 {
            0 => votes.x,
            1 => votes.y,
            2 => votes.z,
            _ => votes.w,
        };
        // Only the run's lanes may vote (whatever a driver makes of the others).
        (word >> (self.first % 32)) & ((1 << run) - 1)
    }

    #[cfg(not(target_arch = "spirv"))]
    #[inline(always)]
    pub fn select(&self, run: u32, keep: impl Fn(W) -> bool) -> u32 {
        (0..run).filter(|&k| keep(self.words[k as usize])).fold(0, |mask, k| mask | 1 << k)
    }
}

/// A value the lanes of a group pass round: a word of a buffer, or a key.
pub trait LaneValue: Copy + PartialOrd {
    /// What the host reads past the end of a buffer.
    #[cfg(not(target_arch = "spirv"))]
    const ZERO: Self;
    /// Subgroup lane `lane`'s value.
    #[cfg(target_arch = "spirv")]
    fn shuffle(self, lane: u32) -> Self;
    /// This lane's value, swapped with lane `self ^ mask`'s.
    #[cfg(target_arch = "spirv")]
    fn shuffle_xor(self, mask: u32) -> Self;
}

impl LaneValue for u32 {
    #[cfg(not(target_arch = "spirv"))]
    const ZERO: u32 = 0;
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    fn shuffle(self, lane: u32) -> u32 {
        spirv_std::arch::subgroup_shuffle(self, lane)
    }
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    fn shuffle_xor(self, mask: u32) -> u32 {
        spirv_std::arch::subgroup_shuffle_xor(self, mask)
    }
}

/// A `u64` goes round as its two halves: a subgroup operation on 64-bit integers needs
/// Vulkan's `shaderSubgroupExtendedTypes`, which wgpu does not enable.
impl LaneValue for u64 {
    #[cfg(not(target_arch = "spirv"))]
    const ZERO: u64 = 0;
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    fn shuffle(self, lane: u32) -> u64 {
        let (lo, hi) = halves(self);
        (hi.shuffle(lane) as u64) << 32 | lo.shuffle(lane) as u64
    }
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    fn shuffle_xor(self, mask: u32) -> u64 {
        let (lo, hi) = halves(self);
        (hi.shuffle_xor(mask) as u64) << 32 | lo.shuffle_xor(mask) as u64
    }
}

impl<W: LaneValue> Words8<W> {
    /// The smallest `f(word k)` over the words `k < run`, `none` if there are none: on the GPU
    /// each lane computes its own word's and the group takes the minimum.
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    pub fn min_of<K: LaneValue>(&self, run: u32, none: K, f: impl Fn(W) -> K) -> K {
        let mut v = if self.lane < run { f(self.mine) } else { none };
        let mut mask = 1;
        while mask < LANE_GROUP {
            let other = v.shuffle_xor(mask);
            if other < v {
                v = other;
            }
            mask <<= 1;
        }
        v
    }

    #[cfg(not(target_arch = "spirv"))]
    #[inline(always)]
    pub fn min_of<K: LaneValue>(&self, run: u32, none: K, f: impl Fn(W) -> K) -> K {
        (0..run).map(|k| f(self.words[k as usize])).fold(none, |a, b| if b < a { b } else { a })
    }
}

impl Lanes {
    /// The bitwise OR of `v` over the group's lanes; on the host, `v`. (The walks OR their
    /// lanes' span bits: whatever the device's order of subgroup lanes against invocations, a
    /// group votes for every span its pixels lie in.)
    #[cfg(target_arch = "spirv")]
    #[inline(always)]
    pub fn group_or(&self, v: u32) -> u32 {
        let a = v | spirv_std::arch::subgroup_shuffle_xor(v, 1);
        let b = a | spirv_std::arch::subgroup_shuffle_xor(a, 2);
        b | spirv_std::arch::subgroup_shuffle_xor(b, 4)
    }

    #[cfg(not(target_arch = "spirv"))]
    #[inline(always)]
    pub fn group_or(&self, v: u32) -> u32 {
        v
    }
}

/// The low and high halves of a 64-bit word.
#[inline(always)]
pub fn halves(word: u64) -> (u32, u32) {
    (word as u32, (word >> 32) as u32)
}
