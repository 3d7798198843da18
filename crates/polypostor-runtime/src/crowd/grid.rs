//! The occupancy grid: a square of cells one minimum distance wide, each holding at most one
//! agent. Two agents closer than a cell width sit in the same or in adjacent cells, so a step
//! only needs to look at the 3×3 cells around where it lands. A border ring of cells that
//! stays empty saves the bounds tests.

use glam::Vec2;

const EMPTY: u32 = u32::MAX;

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
        self.cells.get(cell).copied().filter(|&a| a != EMPTY)
    }

    /// Puts `agent` in `cell`, replacing whatever was there (`u32::MAX` reads back as empty).
    /// Panics when `cell` is out of range.
    pub fn set(&mut self, cell: usize, agent: u32) {
        self.cells[cell] = agent;
    }

    /// Empties `cell`. Panics when it is out of range.
    pub fn clear(&mut self, cell: usize) {
        self.cells[cell] = EMPTY;
    }

    /// Whether an agent other than `me` in the 3×3 cells around `cell` (an inner cell) lies
    /// closer than `sqrt(min2)` to `p`; `pos` are the agents' positions.
    pub fn crowded(&self, cell: usize, p: Vec2, min2: f32, me: u32, pos: &[Vec2]) -> bool {
        for row in [cell - self.stride, cell, cell + self.stride] {
            for &a in &self.cells[row - 1..=row + 1] {
                if a != EMPTY && a != me && pos[a as usize].distance_squared(p) < min2 {
                    return true;
                }
            }
        }
        false
    }
}
