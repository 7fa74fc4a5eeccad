//! The criterion benches of every stage of the table (`vplgi_frame::stage_table!`), CPU and GPU,
//! at a small and the paper's size, one module per stage (a stage's parts are benched in its
//! module). One stage: `cargo bench -p vplgi-benches --bench stages -- '^visibility/'`.

use vplgi_frame::stage_table;

macro_rules! stage_benches {
    ($($(#[$doc:meta])* $name:ident $Trait:ident [$($part:ident $Part:ident),*],)*) => {
        $(mod $name;)*
        criterion::criterion_main!($($name::benches),*);
    };
}
stage_table!(stage_benches);
