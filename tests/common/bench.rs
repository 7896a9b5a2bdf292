//! Bench files for the tests of `--bench` and `-d`.

use std::path::Path;

/// The simulated bench of the docs, its devices named: shoulder =
/// powercube:3, elbow = powercube:5, slide = pac:2, gripper = cdios:1/0.
pub const SIM_BENCH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/sim-bench.toml");

/// Writes `text` as `dir/bench.toml`; its path.
pub fn bench_file(dir: &Path, text: &str) -> String {
    let path = dir.join("bench.toml");
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// A bench whose first PowerCube link is a port that does not exist (a
/// command that opened it would fail with exit 3), with `far` on it, and
/// `arm` (module 3) on the in-process bench.
pub fn two_cube_links(dir: &Path) -> String {
    bench_file(
        dir,
        "[[link]]\nspec = \"slcan:/dev/axisctl-no-such-tty\"\nfamilies = [\"powercube\"]\n\
         devices = { far = \"powercube:5\" }\n\
         [[link]]\nspec = \"sim\"\nfamilies = [\"powercube\", \"pac\", \"cdios\"]\n\
         devices = { arm = \"powercube:3\" }\n",
    )
}
