//! What build this binary is, for `parrt --version`: the text `parrt_render::build_info` puts together
//! for both binaries (version, git commit, profile, target, tier), from the constants
//! `master/build.rs` records for this package.

/// The version text clap prints for `parrt --version` (and every subcommand's), made once.
pub fn text() -> &'static str {
    parrt_render::version_text!()
}

#[cfg(test)]
mod tests {
    #[test]
    fn this_build_knows_its_version_profile_and_target() {
        let b = parrt_render::build_info!();
        assert_eq!(b.version, env!("CARGO_PKG_VERSION"));
        assert!(b.profile == "debug" || b.profile == "release", "{b:?}");
        assert!(!b.target.is_empty());
        assert_eq!(super::text(), b.text());
    }
}
