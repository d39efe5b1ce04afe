//! Where the kernel reads the scene's four small read-only tables from (BVH nodes,
//! triangles, materials, lights): a storage buffer of any size, or a uniform buffer of at
//! most [`UNIFORM_TABLE_BYTES`].
//!
//! Why both. Mesa's lavapipe (22.3, and still 25.0) compiles a storage-buffer read at
//! per-lane offsets into a loop over the eight SIMD lanes that tests each lane's execution
//! mask and bounds and loads it alone (`emit_load_mem` in gallivm's `lp_bld_nir_soa.c`,
//! with a branch per lane that mispredicts as often as the lanes' activity changes), and a
//! uniform-buffer read into a branch-free gather (`emit_load_ubo`'s `build_gather`). The BVH
//! walk is nearly all such reads, so on lavapipe a scene whose tables fit reads them from
//! uniform buffers, which made the Cornell box render 1.78× faster there
//! (`bench/history/lavapipe.md`, "the scene's small tables in uniform buffers"). On
//! a hardware GPU nothing changes: divergent reads of a uniform buffer serialise in the
//! constant cache of NVIDIA's and AMD's GPUs, and storage buffers are their fast path.
//!
//! Lavapipe's other habit with uniform buffers, compiling a new kernel variant whenever one
//! whose values steer branches is re-bound (shaders/bindings.wgsl, issue 6), concerns values
//! read at fixed offsets; the tables are read at per-lane ones, and tests/gpu_memory.rs,
//! whose Cornell box reads all four from uniform buffers on lavapipe, holds the memory
//! constant.
//!
//! The kernel's source declares each table in its form (`declarations`), so each
//! combination of forms is a module of its own; the host pads a uniform table to the
//! declared array's size, which WebGPU requires a binding to have.

use crate::scene::layout::{BvhNode, GpuStruct, Light, Material, Triangle};
use crate::scene::FlatScene;

/// A uniform table's size: WebGPU's guaranteed `maxUniformBufferBindingSize`, and lavapipe's.
pub const UNIFORM_TABLE_BYTES: usize = 64 << 10;

/// Which of the four tables the kernel reads from a uniform buffer (the rest from storage
/// buffers). The default, all storage, serves any scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct UniformTables {
    pub nodes: bool,
    pub triangles: bool,
    pub materials: bool,
    pub lights: bool,
}

/// The tables' bindings in group 0 (the kernel's other bindings are in shaders/bindings.wgsl).
pub const NODES_BINDING: u32 = 0;
pub const TRIANGLES_BINDING: u32 = 1;
pub const MATERIALS_BINDING: u32 = 3;
pub const LIGHTS_BINDING: u32 = 4;

/// One table: its binding, WGSL name, and its record's WGSL struct name and size.
struct Table {
    binding: u32,
    name: &'static str,
    record: &'static str,
    record_bytes: usize,
}

impl Table {
    /// The table of `T` records at `binding`, named `name` in the kernel.
    const fn of<T: GpuStruct>(binding: u32, name: &'static str) -> Table {
        Table { binding, name, record: T::NAME, record_bytes: std::mem::size_of::<T>() }
    }

    /// How many records the table holds as a uniform array.
    const fn capacity(&self) -> usize {
        UNIFORM_TABLE_BYTES / self.record_bytes
    }
}

/// How many tables there are: each needs a uniform-buffer binding when it is one.
pub const TABLE_COUNT: usize = 4;

const TABLES: [Table; TABLE_COUNT] = [
    Table::of::<BvhNode>(NODES_BINDING, "nodes"),
    Table::of::<Triangle>(TRIANGLES_BINDING, "triangles"),
    Table::of::<Material>(MATERIALS_BINDING, "materials"),
    Table::of::<Light>(LIGHTS_BINDING, "lights"),
];

impl UniformTables {
    /// Every table that fits, each on its own: what a software adapter reads `scene` with.
    pub fn fitting(scene: &FlatScene) -> UniformTables {
        // A scene without lights binds one unused record (`GpuBackend::with_kernel`).
        let [nodes, triangles, materials, lights] =
            Self::counts(scene).map(|(count, capacity)| count <= capacity);
        UniformTables { nodes, triangles, materials, lights }
    }

    /// Every table in a uniform buffer, for tests that compare the two forms.
    pub const ALL: UniformTables =
        UniformTables { nodes: true, triangles: true, materials: true, lights: true };

    /// Each table with whether these forms read it from a uniform buffer, in [`TABLES`] order.
    fn entries(self) -> impl Iterator<Item = (&'static Table, bool)> {
        TABLES.iter().zip([self.nodes, self.triangles, self.materials, self.lights])
    }

    /// (records, uniform capacity) of each table of `scene`, in [`TABLES`] order.
    fn counts(scene: &FlatScene) -> [(usize, usize); TABLE_COUNT] {
        let records =
            [scene.nodes.len(), scene.triangles.len(), scene.materials.len(), scene.lights.len().max(1)];
        std::array::from_fn(|i| (records[i], TABLES[i].capacity()))
    }

    /// `None` if every uniform table of these forms holds `scene`'s records, else what does
    /// not fit.
    pub fn misfit(self, scene: &FlatScene) -> Option<String> {
        let counts = Self::counts(scene);
        self.entries().zip(counts).find_map(|((table, uniform), (count, capacity))| {
            (uniform && count > capacity).then(|| {
                format!(
                    "the kernel reads {} from a uniform buffer of {capacity} records; the scene has {count}",
                    table.name
                )
            })
        })
    }

    /// Is binding `binding` one of the tables, and a uniform buffer in these forms?
    pub fn is_uniform(self, binding: u32) -> bool {
        self.entries().any(|(t, uniform)| t.binding == binding && uniform)
    }

    /// The four tables' WGSL declarations in these forms.
    pub fn declarations(self) -> String {
        let mut out = String::from(
            "// The scene's small tables, declared by src/gpu/tables.rs in the forms this kernel\n\
             // reads them in (storage, or uniform where a software adapter gains by it).\n",
        );
        for (t, uniform) in self.entries() {
            let (binding, name, record) = (t.binding, t.name, t.record);
            if uniform {
                out.push_str(&format!(
                    "@group(0) @binding({binding}) var<uniform> {name}: array<{record}, {}>;\n",
                    t.capacity()
                ));
            } else {
                out.push_str(&format!(
                    "@group(0) @binding({binding}) var<storage, read> {name}: array<{record}>;\n"
                ));
            }
        }
        out
    }

    /// A short description for kernel names and bench rows: "uniform nodes, triangles".
    pub fn describe(self) -> String {
        let uniform: Vec<&str> = self.entries().filter(|(_, u)| *u).map(|(t, _)| t.name).collect();
        if uniform.is_empty() {
            "storage tables".into()
        } else {
            format!("uniform {}", uniform.join(", "))
        }
    }

    /// `bytes` as a uniform table's contents: zero-padded to the declared array's size.
    pub fn padded(bytes: &[u8]) -> Vec<u8> {
        let mut out = bytes.to_vec();
        out.resize(UNIFORM_TABLE_BYTES.max(bytes.len()), 0);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_arrays_hold_records_and_keep_uniform_strides() {
        // WGSL requires a uniform array's element stride to be a multiple of 16, and a
        // table must hold at least one record.
        for t in &TABLES {
            assert_eq!(t.record_bytes % 16, 0, "{}", t.name);
            assert!(t.capacity() > 0, "{}", t.name);
        }
        assert_eq!(TABLES[0].capacity(), 2048);
    }

    #[test]
    fn declarations_name_each_form() {
        let storage = UniformTables::default().declarations();
        assert!(storage.contains("@group(0) @binding(0) var<storage, read> nodes: array<BvhNode>;"));
        let mixed = UniformTables { nodes: true, lights: true, ..Default::default() };
        let text = mixed.declarations();
        assert!(text.contains("@group(0) @binding(0) var<uniform> nodes: array<BvhNode, 2048>;"));
        assert!(text.contains("@group(0) @binding(1) var<storage, read> triangles: array<Triangle>;"));
        assert!(text.contains("var<uniform> lights: array<Light, 1024>;"));
        assert!(UniformTables::ALL.is_uniform(3) && !UniformTables::default().is_uniform(3));
        assert!(!UniformTables::ALL.is_uniform(2), "normals are always a storage buffer");
        assert_eq!(mixed.describe(), "uniform nodes, lights");
    }
}
