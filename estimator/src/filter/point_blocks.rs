//! Cubature or sigma points stored for the batched model calls (see
//! `model.rs`): block `b` holds points `8b … 8b + 7` as `dim` rows of one
//! [`Component`] each, so a block is passed to the model as it lies.
//!
//! The lanes after the last point are padding. They hold a copy of a real
//! point (the mean), so that a model never sees made-up states and whatever
//! it returns for them is a value it would return anyway.

use std::slice::{ChunksExact, ChunksExactMut};

use crate::model::{Component, BLOCK_POINTS};

#[derive(Debug, Clone)]
pub(crate) struct PointBlocks {
    dim: usize,
    count: usize,
    data: Vec<Component>,
}

impl PointBlocks {
    /// `count` points of dimension `dim`, all zero.
    pub(crate) fn new(dim: usize, count: usize) -> Self {
        Self { dim, count, data: vec![[0.0; BLOCK_POINTS]; count.div_ceil(BLOCK_POINTS) * dim] }
    }

    /// The blocks, `dim` rows each.
    pub(crate) fn blocks(&self) -> ChunksExact<'_, Component> {
        self.data.chunks_exact(self.dim.max(1))
    }

    /// The blocks, to be written.
    pub(crate) fn blocks_mut(&mut self) -> ChunksExactMut<'_, Component> {
        self.data.chunks_exact_mut(self.dim.max(1))
    }

    /// Component `i` of point `p`.
    #[inline(always)]
    pub(crate) fn get(&self, i: usize, p: usize) -> f64 {
        self.data[(p / BLOCK_POINTS) * self.dim + i][p % BLOCK_POINTS]
    }

    /// Loads points stored one per column (`dim × count`, column-major), and
    /// `pad` into the padding.
    #[inline(always)]
    pub(crate) fn load_columns(&mut self, points: &[f64], pad: &[f64]) {
        let dim = self.dim;
        for (p, point) in points.chunks_exact(dim).take(self.count).enumerate() {
            let block = &mut self.data[(p / BLOCK_POINTS) * dim..][..dim];
            for (component, &value) in block.iter_mut().zip(point) {
                component[p % BLOCK_POINTS] = value;
            }
        }
        self.pad_with(pad);
    }

    /// Stores the points one per column (`dim × count`, column-major).
    #[inline(always)]
    pub(crate) fn store_columns(&self, points: &mut [f64]) {
        let dim = self.dim;
        for (p, point) in points.chunks_exact_mut(dim).take(self.count).enumerate() {
            let block = &self.data[(p / BLOCK_POINTS) * dim..][..dim];
            for (value, component) in point.iter_mut().zip(block) {
                *value = component[p % BLOCK_POINTS];
            }
        }
    }

    /// Copies component `i` at every point, in point order, into `out` (`count` values).
    #[inline(always)]
    pub(crate) fn copy_component(&self, i: usize, out: &mut [f64]) {
        debug_assert_eq!(out.len(), self.count);
        let (whole, rest) = out.as_chunks_mut::<BLOCK_POINTS>();
        let mut blocks = self.blocks();
        for (chunk, block) in whole.iter_mut().zip(&mut blocks) {
            *chunk = block[i];
        }
        if let Some(block) = blocks.next() {
            rest.copy_from_slice(&block[i][..rest.len()]);
        }
    }

    /// Sets component `i` of every point, padding included, from `values`
    /// (whole blocks: `count` rounded up to a multiple of the block size).
    #[inline(always)]
    pub(crate) fn set_component(&mut self, i: usize, values: &[f64]) {
        let (whole, rest) = values.as_chunks::<BLOCK_POINTS>();
        debug_assert!(rest.is_empty() && whole.len() == self.data.len() / self.dim.max(1));
        for (block, chunk) in self.blocks_mut().zip(whole) {
            block[i] = *chunk;
        }
    }

    /// The number of values [`PointBlocks::set_component`] takes.
    pub(crate) fn padded_count(&self) -> usize {
        self.count.div_ceil(BLOCK_POINTS) * BLOCK_POINTS
    }

    /// Copies `point` into the padding lanes.
    fn pad_with(&mut self, point: &[f64]) {
        let (first_pad, dim) = (self.count % BLOCK_POINTS, self.dim);
        if first_pad == 0 || dim == 0 {
            return;
        }
        let start = self.data.len() - dim;
        let last = &mut self.data[start..];
        for (component, &value) in last.iter_mut().zip(point) {
            component[first_pad..].fill(value);
        }
    }

    /// Every value, padding included.
    pub(crate) fn values(&self) -> &[f64] {
        self.data.as_flattened()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_round_trip_and_padding_holds_the_given_point() {
        let (dim, count) = (3, 11);
        let columns: Vec<f64> = (0..count).flat_map(|p| (0..dim).map(move |i| (10 * p + i) as f64)).collect();
        let mut points = PointBlocks::new(dim, count);
        points.load_columns(&columns, &[-1.0, -2.0, -3.0]);
        for i in 0..dim {
            let expected: Vec<f64> = (0..count).map(|p| (10 * p + i) as f64).collect();
            let mut component = vec![0.0; count];
            points.copy_component(i, &mut component);
            assert_eq!(component, expected);
        }
        let blocks: Vec<&[Component]> = points.blocks().collect();
        assert_eq!(blocks.len(), 2);
        assert_eq!(blocks[1][2], [82.0, 92.0, 102.0, -3.0, -3.0, -3.0, -3.0, -3.0]);
        assert_eq!(points.values().len(), 2 * dim * BLOCK_POINTS);
        assert_eq!(points.get(1, 9), 91.0);

        let mut stored = vec![0.0; dim * count];
        points.store_columns(&mut stored);
        assert_eq!(stored, columns);
        let mut again = PointBlocks::new(dim, count);
        again.load_columns(&stored, &[-1.0, -2.0, -3.0]);
        assert_eq!(again.values(), points.values());

        // Component by component, padding included.
        let mut set = PointBlocks::new(dim, count);
        assert_eq!(set.padded_count(), 16);
        for i in 0..dim {
            let row: Vec<f64> =
                (0..16).map(|p| if p < count { (10 * p + i) as f64 } else { -1.0 - i as f64 }).collect();
            set.set_component(i, &row);
        }
        assert_eq!(set.values(), points.values());
    }
}
