//! `parrt-worker --version` names the build as `parrt --version` does: the one text
//! `parrt_render::build_info` puts together, from the constants this package's build script records.

use std::process::Command;

#[test]
fn version_names_the_build_like_parrt() {
    let o = Command::new(env!("CARGO_BIN_EXE_parrt-worker"))
        .arg("--version")
        .output()
        .expect("the parrt-worker binary runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = String::from_utf8_lossy(&o.stdout).into_owned();
    // The same constants and the same tier (this process and the child see one CPU and one
    // PARRT_ISA), so the very text.
    assert_eq!(
        v,
        format!("parrt-worker {}\n", parrt_render::version_text!())
    );
    for part in ["commit ", " build, ", std::env::consts::ARCH, ", tier "] {
        assert!(v.contains(part), "{part:?} missing from {v:?}");
    }
}
