//! Verlet neighbour list built with cell lists: O(N) construction, rebuilt only when some
//! particle has moved more than half the skin (or the box has changed by as much).
//!
//! The list is a half list: each pair (i, j) with i < j appears once, sorted by i then j, stored
//! as `pi` (first particle) and `pair` (second particle and its periodic image) with a CSR index
//! `start` by i, so that the pairs of a block of particles form one contiguous range.
//!
//! As in LAMMPS, particles are wrapped into the box only when the list is rebuilt; in between,
//! each pair keeps the periodic image chosen at build time (`image`), so the force loop needs no
//! minimum-image arithmetic: `r_i - r_j - domain.image_shift(k)`.

use rayon::prelude::*;

use super::Domain;
use crate::math::{Real, Vec3};

const CHUNK: usize = 512;

/// The second member of a listed pair.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PairRef {
    /// Index of the second particle.
    pub j: u32,
    /// Periods crossed along x, y, z to reach the image of j that interacts with i.
    pub image: [i8; 3],
}

/// Half neighbour list with Verlet skin.
#[derive(Debug, Clone, Default)]
pub struct NeighborList {
    /// First particle of each pair.
    pub pi: Vec<u32>,
    /// Second particle of each pair (j > i) and the periodic image of it that i sees.
    pub pair: Vec<PairRef>,
    /// Pairs of particle i are `start[i]..start[i + 1]`.
    pub start: Vec<u32>,
    /// Pairs closer than `R_i + R_j + reach` are kept, m.
    pub reach: Real,
    /// Skin, m (part of `reach`).
    pub skin: Real,
    /// Number of builds so far.
    pub builds: u64,
    ref_pos: Vec<Vec3>,
    ref_offset: Real,
    ref_len: Vec3,
    cell_start: Vec<u32>,
    cell_items: Vec<u32>,
}

impl NeighborList {
    /// An empty list keeping pairs closer than `R_i + R_j + range + skin`.
    pub fn new(range: Real, skin: Real) -> Self {
        Self { reach: range + skin, skin, ..Default::default() }
    }

    /// Separation `r_i - r_j'` of pair `q` with its build-time image, and the x-velocity of that
    /// image relative to j (Lees-Edwards).
    #[inline(always)]
    pub fn separation(&self, q: usize, pos: &[Vec3], domain: &Domain) -> (Vec3, Real) {
        let PairRef { j, image } = self.pair[q];
        let d = pos[self.pi[q] as usize] - pos[j as usize] - domain.image_shift(image);
        (d, domain.image_velocity(image[1]))
    }

    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.pi.len()
    }

    /// True if there is no pair.
    pub fn is_empty(&self) -> bool {
        self.pi.is_empty()
    }

    /// True if the list may miss an interacting pair: twice the largest displacement since the
    /// last build, plus the change of Lees-Edwards offset and box lengths, exceeds the skin.
    pub fn needs_rebuild(&self, pos: &[Vec3], domain: &Domain) -> bool {
        if self.ref_pos.len() != pos.len() {
            return true;
        }
        // Positions are not wrapped between builds, so plain differences are displacements.
        let max2 = pos
            .par_chunks(4 * CHUNK)
            .zip(self.ref_pos.par_chunks(4 * CHUNK))
            .map(|(ps, rs)| ps.iter().zip(rs).map(|(p, r)| (p - r).norm_squared()).fold(0.0, f64::max))
            .reduce(|| 0.0, f64::max);
        self.needs_rebuild_after(max2, domain)
    }

    /// Positions at the last build (empty before the first), for a caller that measures the
    /// displacements in a pass of its own ([`NeighborList::needs_rebuild_after`]).
    pub fn reference_positions(&self) -> &[Vec3] {
        &self.ref_pos
    }

    /// [`NeighborList::needs_rebuild`] given `max2`, the largest squared displacement of a
    /// particle from [`NeighborList::reference_positions`] (m²), measured over as many
    /// particles as that holds (fewer or more particles than at the last build: call
    /// `needs_rebuild`).
    pub fn needs_rebuild_after(&self, max2: Real, domain: &Domain) -> bool {
        let mut drift = 2.0 * max2.sqrt();
        if domain.shifted_images() {
            // Not the distance modulo L_x: when the offset wraps around the box, every pair
            // listed across the sheared boundary refers to an image one period away.
            drift += (domain.le_offset - self.ref_offset).abs();
        }
        for a in 0..domain.dim {
            if domain.periodic[a] {
                drift += (domain.length(a) - self.ref_len[a]).abs();
            }
        }
        drift > self.skin
    }

    /// Rebuilds the list; `pos` must be wrapped into the box. Pair states carried over use
    /// [`NeighborList::find`] to locate their pair in the new list.
    pub fn rebuild(&mut self, pos: &[Vec3], radius: &[Real], domain: &Domain) {
        let n = pos.len();
        let rmax = radius.iter().copied().fold(0.0, f64::max);
        let cell_size = 2.0 * rmax + self.reach;
        // Grid extents: the box on periodic axes, the particles' bounding box elsewhere.
        let mut lo = Vec3::zeros();
        let mut ncell = [1usize; 3];
        let mut width = Vec3::repeat(1.0);
        for a in 0..domain.dim {
            let (l0, l1) = if domain.periodic[a] {
                (domain.lo[a], domain.hi[a])
            } else {
                let (mn, mx) = pos.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(mn, mx), p| (mn.min(p[a]), mx.max(p[a])));
                if n == 0 {
                    (0.0, 1.0)
                } else {
                    (mn, mx.max(mn + 1e-300))
                }
            };
            let len = (l1 - l0).max(f64::MIN_POSITIVE);
            // Cap the grid so a few particles far apart cannot ask for a huge number of cells.
            let cap = (4 * n.max(1)) as f64;
            let k = ((len / cell_size).floor().max(1.0)).min(cap.powf(1.0 / domain.dim as f64).max(1.0));
            ncell[a] = k as usize;
            lo[a] = l0;
            width[a] = len / k;
        }
        let ncells = ncell[0] * ncell[1] * ncell[2];
        let cell_of = |p: &Vec3| -> [usize; 3] {
            let mut c = [0usize; 3];
            for a in 0..domain.dim {
                let k = ((p[a] - lo[a]) / width[a]).floor();
                c[a] = (k.max(0.0) as usize).min(ncell[a] - 1);
            }
            c
        };
        let flat = |c: [usize; 3]| (c[2] * ncell[1] + c[1]) * ncell[0] + c[0];
        // Counting sort into cells.
        self.cell_start.clear();
        self.cell_start.resize(ncells + 1, 0);
        let cells: Vec<u32> = pos.par_iter().with_min_len(4 * CHUNK).map(|p| flat(cell_of(p)) as u32).collect();
        for &c in &cells {
            self.cell_start[c as usize + 1] += 1;
        }
        for k in 0..ncells {
            self.cell_start[k + 1] += self.cell_start[k];
        }
        self.cell_items.clear();
        self.cell_items.resize(n, 0);
        let mut fill = self.cell_start.clone();
        for (i, &c) in cells.iter().enumerate() {
            self.cell_items[fill[c as usize] as usize] = i as u32;
            fill[c as usize] += 1;
        }

        let reach = self.reach;
        let cell_start = &self.cell_start;
        let cell_items = &self.cell_items;
        let le_shift = |dy_wrap: i64| -> i64 {
            // Image rows one period up (dy_wrap = +1) are shifted by +offset along x.
            if !domain.shifted_images() || dy_wrap == 0 {
                return 0;
            }
            (dy_wrap as f64 * domain.le_offset / width[0]).floor() as i64
        };
        let dims = domain.dim;
        // Without Lees-Edwards and with at least three cells along every periodic axis, the 3^D
        // cells around a particle are distinct and the image of each is the number of periods
        // its index wrapped: the candidates need no minimum-image search.
        let by_cell_image = !domain.shifted_images() && (0..dims).all(|a| !domain.periodic[a] || ncell[a] >= 3);
        let chunks: Vec<(Vec<u32>, Vec<PairRef>)> = (0..n)
            .into_par_iter()
            .chunks(CHUNK)
            .map(|idx| {
                let mut counts = Vec::with_capacity(idx.len());
                let mut js = Vec::with_capacity(idx.len() * 8);
                let mut nb_cells: Vec<usize> = Vec::with_capacity(64);
                for &i in &idx {
                    let ci = cell_of(&pos[i]);
                    if by_cell_image {
                        let (pi, ri) = (pos[i], radius[i]);
                        let before = js.len();
                        let range = |a: usize| if a < dims { -1i64..=1 } else { 0i64..=0 };
                        let mut scan = |first: usize, last: usize, image: [i8; 3]| {
                            let base = pi - domain.image_shift(image);
                            for &j in &cell_items[cell_start[first] as usize..cell_start[last + 1] as usize] {
                                if (j as usize) <= i {
                                    continue;
                                }
                                let d = base - pos[j as usize];
                                let cut = ri + radius[j as usize] + reach;
                                if d.norm_squared() < cut * cut {
                                    js.push(PairRef { j, image });
                                }
                            }
                        };
                        for dz in range(2) {
                            let (Some(z), wz) = wrap_index(ci[2] as i64 + dz, ncell[2], domain.periodic[2]) else { continue };
                            for dy in range(1) {
                                let (Some(y), wy) = wrap_index(ci[1] as i64 + dy, ncell[1], domain.periodic[1]) else { continue };
                                let row = flat([0, y, z]);
                                let cx = ci[0];
                                if cx >= 1 && cx + 1 < ncell[0] {
                                    // The three cells along x, none wrapped, are one run of
                                    // `cell_items`.
                                    scan(row + cx - 1, row + cx + 1, [0, wy as i8, wz as i8]);
                                } else {
                                    for dx in -1i64..=1 {
                                        let (Some(x), wx) = wrap_index(cx as i64 + dx, ncell[0], domain.periodic[0]) else { continue };
                                        scan(row + x, row + x, [wx as i8, wy as i8, wz as i8]);
                                    }
                                }
                            }
                        }
                        js[before..].sort_unstable_by_key(|e| e.j);
                        counts.push((js.len() - before) as u32);
                        continue;
                    }
                    nb_cells.clear();
                    let range = |a: usize| if a < dims { -1i64..=1 } else { 0i64..=0 };
                    for dz in range(2) {
                        for dy in range(1) {
                            // Row index along y, wrapped; remember whether it crossed the boundary.
                            let y = ci[1] as i64 + dy;
                            let (y, wrap) = wrap_index(y, ncell[1], domain.periodic[1]);
                            let Some(y) = y else { continue };
                            let shift = le_shift(wrap);
                            // Image x = x_j + wrap * offset must fall within one cell of i:
                            // x_j's cell lies in [cx - 2 - shift, cx + 1 - shift].
                            let dxs: std::ops::RangeInclusive<i64> =
                                if wrap != 0 && domain.shifted_images() { -2 - shift..=1 - shift } else { -1..=1 };
                            for dx in dxs {
                                let (x, _) = wrap_index(ci[0] as i64 + dx, ncell[0], domain.periodic[0]);
                                let Some(x) = x else { continue };
                                let (z, _) = wrap_index(ci[2] as i64 + dz, ncell[2], domain.periodic[2]);
                                let Some(z) = z else { continue };
                                nb_cells.push(flat([x, y, z]));
                            }
                        }
                    }
                    nb_cells.sort_unstable();
                    nb_cells.dedup();
                    let before = js.len();
                    for &c in &nb_cells {
                        for &j in &cell_items[cell_start[c] as usize..cell_start[c + 1] as usize] {
                            if (j as usize) <= i {
                                continue;
                            }
                            let (d, k) = domain.image(&pos[i], &pos[j as usize]);
                            let cut = radius[i] + radius[j as usize] + reach;
                            if d.norm_squared() < cut * cut {
                                js.push(PairRef { j, image: k });
                            }
                        }
                    }
                    js[before..].sort_unstable_by_key(|e| e.j);
                    counts.push((js.len() - before) as u32);
                }
                (counts, js)
            })
            .collect();

        // Concatenate the chunks in parallel: each writes its own slices of the arrays.
        let total: usize = chunks.iter().map(|c| c.1.len()).sum();
        self.start.resize(n + 1, 0);
        self.pi.resize(total, 0);
        self.pair.resize(total, PairRef::default());
        self.start[0] = 0;
        let mut parts = Vec::with_capacity(chunks.len());
        let (mut pis, mut pairs, mut starts) = (&mut self.pi[..], &mut self.pair[..], &mut self.start[1..]);
        let (mut first_pair, mut first_particle) = (0usize, 0usize);
        for (counts, js) in &chunks {
            let (a, rest) = std::mem::take(&mut pis).split_at_mut(js.len());
            pis = rest;
            let (b, rest) = std::mem::take(&mut pairs).split_at_mut(js.len());
            pairs = rest;
            let (c, rest) = std::mem::take(&mut starts).split_at_mut(counts.len());
            starts = rest;
            parts.push((a, b, c, counts, js, first_pair, first_particle));
            first_pair += js.len();
            first_particle += counts.len();
        }
        parts.into_par_iter().for_each(|(pis, pairs, starts, counts, js, first_pair, first_particle)| {
            pairs.copy_from_slice(js);
            let (mut end, mut k) = (first_pair, 0usize);
            for (m, &c) in counts.iter().enumerate() {
                end += c as usize;
                starts[m] = end as u32;
                pis[k..k + c as usize].fill((first_particle + m) as u32);
                k += c as usize;
            }
        });
        self.ref_pos.clear();
        self.ref_pos.extend_from_slice(pos);
        self.ref_offset = domain.le_offset;
        self.ref_len = domain.hi - domain.lo;
        self.builds += 1;
    }

    /// Index of the pair (i, j), i < j, in the list, if listed.
    #[inline]
    pub fn find(&self, i: u32, j: u32) -> Option<usize> {
        let (s, e) = (*self.start.get(i as usize)? as usize, *self.start.get(i as usize + 1)? as usize);
        self.pair[s..e].binary_search_by_key(&j, |r| r.j).ok().map(|k| s + k)
    }

    /// Heap bytes held by the list.
    pub fn heap_bytes(&self) -> usize {
        4 * (self.pi.capacity() + self.start.capacity())
            + std::mem::size_of::<PairRef>() * self.pair.capacity()
            + 4 * (self.cell_start.capacity() + self.cell_items.capacity())
            + std::mem::size_of::<Vec3>() * self.ref_pos.capacity()
    }
}

/// Wraps a cell index on a periodic axis; `None` outside a non-periodic grid. The second value
/// is -1, 0 or +1: how many periods the index crossed.
#[inline(always)]
fn wrap_index(k: i64, n: usize, periodic: bool) -> (Option<usize>, i64) {
    let n = n as i64;
    if (0..n).contains(&k) {
        (Some(k as usize), 0)
    } else if periodic {
        let w = k.div_euclid(n);
        (Some(k.rem_euclid(n) as usize), w)
    } else {
        (None, 0)
    }
}
