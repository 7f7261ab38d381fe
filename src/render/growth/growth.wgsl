// One step of the cloud-growth automaton (Dobashi et al. 2000): each cell's humid, activated and
// cloud bits from its own and its neighbours' bits and three probabilities.
// CPU twin, bit for bit: `src/reference/growth.rs` (the rules are in its docs). The cell bits
// are its constants of the same names (checked by `render/contract.rs`).

const HUM: u32 = 1u;
const ACT: u32 = 2u;
const CLD: u32 = 4u;

// Written by `GpuGrowthUniforms` (Rust); `render/contract.rs` holds the two layouts equal.
struct GrowthUniforms {
    // Cells along x, y (horizontal) and z (up).
    size: vec3<u32>,
    // 24-bit evaporation threshold.
    extinction: u32,
    // The step's hash keys for the humid, activated and cloud bits (Rust `step_key`).
    keys: vec3<u32>,
    // 1 when `columns` holds one entry for every column, 0 for one entry in all.
    per_column: u32,
}

@group(0) @binding(0) var<storage, read> cells_in: array<u32>;
@group(0) @binding(1) var<storage, read_write> cells_out: array<u32>;
// Per column (x fastest): the humidity and activation thresholds, 24-bit.
@group(0) @binding(2) var<storage, read> columns: array<vec2<u32>>;
@group(0) @binding(3) var<uniform> growth: GrowthUniforms;

// PCG hash (Jarzynski & Olano 2020). Rust: `pcg`.
fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// The 24-bit random number of a cell for the bit whose step key is `key`. Rust: `cell_random`.
fn cell_random(key: u32, cell: u32) -> u32 {
    return pcg(key + cell) >> 8u;
}

// `v + d` wrapped into `0..n`, for |d| <= 2 <= n (no division).
fn wrap(v: u32, d: i32, n: u32) -> u32 {
    var s = i32(v) + d;
    if s < 0 {
        s += i32(n);
    } else if s >= i32(n) {
        s -= i32(n);
    }
    return u32(s);
}

fn index_of(p: vec3<u32>) -> u32 {
    return p.x + growth.size.x * (p.y + growth.size.y * p.z);
}

// Whether the cell at `p + d` is activated: wrapping horizontally, false outside vertically.
fn activated(p: vec3<u32>, d: vec3<i32>) -> bool {
    let z = i32(p.z) + d.z;
    if z < 0 || z >= i32(growth.size.z) {
        return false;
    }
    let q = vec3<u32>(wrap(p.x, d.x, growth.size.x), wrap(p.y, d.y, growth.size.y), u32(z));
    return (cells_in[index_of(q)] & ACT) != 0u;
}

@compute @workgroup_size(8, 8, 1)
fn grow(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id >= growth.size) {
        return;
    }
    // The neighbours whose activation spreads: Rust `NEIGHBOURS`.
    let f_act = activated(id, vec3(1, 0, 0)) || activated(id, vec3(-1, 0, 0))
        || activated(id, vec3(0, 1, 0)) || activated(id, vec3(0, -1, 0))
        || activated(id, vec3(0, 0, 1)) || activated(id, vec3(0, 0, -1))
        || activated(id, vec3(2, 0, 0)) || activated(id, vec3(-2, 0, 0))
        || activated(id, vec3(0, 2, 0)) || activated(id, vec3(0, -2, 0))
        || activated(id, vec3(0, 0, -2));
    let i = index_of(id);
    var column = columns[0];
    if growth.per_column != 0u {
        column = columns[id.x + growth.size.x * id.y];
    }
    let cell = cells_in[i];
    let hum = (cell & HUM) != 0u;
    let act = (cell & ACT) != 0u;
    let cld = (cell & CLD) != 0u;
    let hum_next = (hum && !act) || cell_random(growth.keys.x, i) < column.x;
    let act_next = (!act && hum && f_act) || cell_random(growth.keys.y, i) < column.y;
    let cld_next = (cld || act) && !(cell_random(growth.keys.z, i) < growth.extinction);
    cells_out[i] = select(0u, HUM, hum_next) | select(0u, ACT, act_next) | select(0u, CLD, cld_next);
}

// Each column's cloud count (entry `column_counts`, bindings 0, 3 and 5), then the cloud the
// weather reads (entry `column_cover`, bindings 3, 4 and 5): the cloud cells among the
// (2 COVER_RADIUS + 1)^2 columns around the column over all their cells. Rust:
// `GrowthGrid::column_counts`, `GrowthGrid::smoothed_cover`.
const COVER_RADIUS: i32 = 2;

@group(0) @binding(4) var cover_out: texture_storage_2d<r32float, write>;
@group(0) @binding(5) var<storage, read_write> counts: array<u32>;

@compute @workgroup_size(8, 8, 1)
fn column_counts(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= growth.size.x || id.y >= growth.size.y {
        return;
    }
    var count = 0u;
    for (var z = 0u; z < growth.size.z; z++) {
        if (cells_in[index_of(vec3<u32>(id.xy, z))] & CLD) != 0u {
            count += 1u;
        }
    }
    counts[id.x + growth.size.x * id.y] = count;
}

@compute @workgroup_size(8, 8, 1)
fn column_cover(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= growth.size.x || id.y >= growth.size.y {
        return;
    }
    var sum = 0u;
    for (var dy = -COVER_RADIUS; dy <= COVER_RADIUS; dy++) {
        for (var dx = -COVER_RADIUS; dx <= COVER_RADIUS; dx++) {
            let x = wrap(id.x, dx, growth.size.x);
            let y = wrap(id.y, dy, growth.size.y);
            sum += counts[x + growth.size.x * y];
        }
    }
    let side = u32(2 * COVER_RADIUS + 1);
    let cells = side * side * growth.size.z;
    textureStore(cover_out, vec2<i32>(id.xy), vec4<f32>(f32(sum) / f32(cells), 0.0, 0.0, 0.0));
}
