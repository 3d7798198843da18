//! The occupancy grid: a square of cells one minimum distance wide, each holding at most one
//! agent. Two agents closer than a cell width sit in the same or in adjacent cells, so a step
//! only needs to look at the 3×3 cells around where it lands. A border ring of cells that
//! stays empty saves the bounds tests.

use glam::Vec2;

const EMPTY: u32 = u32::MAX;
/// A cell holds its agent's index in the low bits and the agent's kind of character above
/// them, so the per-pair test ([`OccupancyGrid::crowded_by_kind`]) reads no other memory.
const KIND_SHIFT: u32 = 29;
const AGENT_MASK: u32 = (1 << KIND_SHIFT) - 1;
/// Agents a grid can hold: indices below this (the all-ones value marks an empty cell).
pub const MAX_AGENTS: usize = AGENT_MASK as usize;
// Every kind fits the bits above the index.
const _: () = assert!(super::MAX_SPECIES <= 1 << (32 - KIND_SHIFT));

/// The grid over the square ground `[-half_extent, half_extent]²` (x, z): `dim`×`dim` inner
/// cells plus the border ring, each holding at most one agent index. Cell arguments are
/// indices into the whole grid, border included (rows of `dim + 2`), as
/// [`OccupancyGrid::cell_of`] and [`OccupancyGrid::inner`] give them.
#[derive(Clone, Debug)]
pub struct OccupancyGrid {
    /// Cells along a side, the border ring excluded.
    dim: usize,
    stride: usize,
    /// Width of a cell in world units (metres): at least the crowd's minimum distance.
    pub cell: f32,
    inv_cell: f32,
    half_extent: f32,
    cells: Vec<u32>,
}

impl OccupancyGrid {
    /// An empty grid of `dim`×`dim` cells `cell` wide (`dim` at least 1), centred on the origin;
    /// `half_extent` is meant to be `dim · cell / 2`.
    pub fn new(dim: usize, cell: f32, half_extent: f32) -> Self {
        let stride = dim + 2;
        Self {
            dim,
            stride,
            cell,
            inv_cell: 1.0 / cell,
            half_extent,
            cells: vec![EMPTY; stride * stride],
        }
    }

    /// Cells along a side.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The cell holding `p` (positions off the ground clamp to the outermost inner cells).
    pub fn cell_of(&self, p: Vec2) -> usize {
        // `as usize` saturates negative values to 0 and truncates toward zero, which is the
        // floor for the non-negative values that matter.
        let f = |x: f32| (((x + self.half_extent) * self.inv_cell) as usize).min(self.dim - 1) + 1;
        f(p.y) * self.stride + f(p.x)
    }

    /// The `k`-th inner cell (0..dim²), row by row.
    pub fn inner(&self, k: usize) -> usize {
        (k / self.dim + 1) * self.stride + k % self.dim + 1
    }

    /// Centre of inner cell `cell` on the ground (x, z). A cell of the border ring gives the
    /// centre of the inner cell beside it (never an underflow).
    pub fn centre(&self, cell: usize) -> Vec2 {
        let (x, z) = (
            (cell % self.stride).saturating_sub(1),
            (cell / self.stride).saturating_sub(1),
        );
        Vec2::new(
            (x as f32 + 0.5) * self.cell - self.half_extent,
            (z as f32 + 0.5) * self.cell - self.half_extent,
        )
    }

    /// The agent in `cell`; `None` when it is empty (or `cell` is out of range).
    pub fn get(&self, cell: usize) -> Option<u32> {
        self.cells
            .get(cell)
            .copied()
            .filter(|&a| a != EMPTY)
            .map(|a| a & AGENT_MASK)
    }

    /// Puts `agent` (below [`MAX_AGENTS`]), of kind 0, in `cell`, replacing whatever was
    /// there. Panics when `cell` is out of range.
    pub fn set(&mut self, cell: usize, agent: u32) {
        debug_assert!((agent as usize) < MAX_AGENTS);
        self.cells[cell] = agent & AGENT_MASK;
    }

    /// Empties `cell`. Panics when it is out of range.
    pub fn clear(&mut self, cell: usize) {
        self.cells[cell] = EMPTY;
    }

    /// Records the kind of character of the agent in `cell` ([`OccupancyGrid::crowded_by_kind`]
    /// reads it). Panics when `cell` is out of range.
    pub fn set_kind(&mut self, cell: usize, kind: u8) {
        let a = self.cells[cell];
        if a != EMPTY {
            self.cells[cell] = (a & AGENT_MASK) | ((kind as u32 % super::MAX_SPECIES as u32) << KIND_SHIFT);
        }
    }

    /// Moves the agent in `from` (and its kind) to `to`, emptying `from`. Panics when either
    /// is out of range.
    pub fn move_agent(&mut self, from: usize, to: usize) {
        self.cells[to] = self.cells[from];
        self.cells[from] = EMPTY;
    }

    /// Whether an agent other than `me` in the 3×3 cells around `cell` (an inner cell) lies
    /// closer than `sqrt(min2)` to `p`; `pos` are the agents' positions.
    pub fn crowded(&self, cell: usize, p: Vec2, min2: f32, me: u32, pos: &[Vec2]) -> bool {
        for row in [cell - self.stride, cell, cell + self.stride] {
            for &a in &self.cells[row - 1..=row + 1] {
                if a != EMPTY && a & AGENT_MASK != me && pos[(a & AGENT_MASK) as usize].distance_squared(p) < min2 {
                    return true;
                }
            }
        }
        false
    }

    /// [`OccupancyGrid::crowded`] with a distance per pair of characters: whether an agent
    /// other than `me` in the 3×3 cells around `cell` lies closer to `p` than
    /// `sqrt(min2[kind])` (its kind as [`OccupancyGrid::set_kind`] recorded it) and no further
    /// than from `from` (where the agent stands: a pair already too close may move apart).
    /// Every entry of `min2` must be at most the squared cell width (the 3×3 cells then hold
    /// everyone who could be too close).
    pub fn crowded_by_kind(
        &self,
        cell: usize,
        p: Vec2,
        from: Vec2,
        min2: &[f32; super::MAX_SPECIES],
        me: u32,
        pos: &[Vec2],
    ) -> bool {
        for row in [cell - self.stride, cell, cell + self.stride] {
            for &v in &self.cells[row - 1..=row + 1] {
                let a = v & AGENT_MASK;
                if v != EMPTY && a != me {
                    let need = min2[(v >> KIND_SHIFT) as usize % super::MAX_SPECIES];
                    let q = pos[a as usize];
                    let d2 = q.distance_squared(p);
                    if d2 < need && d2 <= q.distance_squared(from) {
                        return true;
                    }
                }
            }
        }
        false
    }
}
