//! The cloud-growth automaton's compute pass against its CPU twin.

use bevy::{
    math::UVec2,
    render::{
        render_resource::TextureFormat,
        renderer::{RenderDevice, RenderQueue},
    },
};
use bevy_cloudscape::{
    reference::growth::{CLD, GrowthGrid, probability_threshold},
    render::growth::GrowthCompute,
};

use crate::harness::Headless;

#[test]
fn the_gpu_automaton_matches_its_cpu_twin_bit_for_bit_over_100_steps() {
    let mut app = Headless::new(UVec2::splat(2), TextureFormat::Rgba8UnormSrgb, |_| {});
    let size = [64, 48, 8];
    let mut grid = GrowthGrid::new(size);
    // Humidity rising eastward, rare random activation, some evaporation: clouds form, grow
    // and vanish, so every rule is exercised.
    let columns: Vec<[u32; 2]> = (0..size[0] * size[1])
        .map(|i| {
            let east = (i % size[0]) as f32 / (size[0] - 1) as f32;
            [
                probability_threshold(0.05 + 0.4 * east),
                probability_threshold(0.002),
            ]
        })
        .collect();
    let extinction = probability_threshold(0.03);
    let seed = 2026;
    let world = app.render_world();
    let device = world.resource::<RenderDevice>().clone();
    let queue = world.resource::<RenderQueue>().clone();
    let mut gpu = GrowthCompute::new(&device, &grid, &columns);
    let mut differing = Vec::new();
    for chunk in 0..4 {
        gpu.step(&device, &queue, seed, extinction, chunk * 25, 25);
        for step in chunk * 25..(chunk + 1) * 25 {
            grid.step(&columns, extinction, seed, step);
        }
        let bytes = app.read_buffer(gpu.cells(), 0, (grid.cells.len() * 4) as u64);
        let cells: Vec<u32> = bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        differing.push(
            cells
                .iter()
                .zip(&grid.cells)
                .filter(|(a, b)| a != b)
                .count(),
        );
    }
    let cloud =
        grid.cells.iter().filter(|&&c| c & CLD != 0).count() as f64 / grid.cells.len() as f64;
    eprintln!(
        "cells that differ after 25, 50, 75, 100 steps: {differing:?}; cloud fraction {cloud:.3}"
    );
    assert_eq!(differing, vec![0; 4]);
    assert!(
        (0.02..0.98).contains(&cloud),
        "a field with cloud and gaps: {cloud}"
    );
}
