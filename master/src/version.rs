//! What build this binary is, for `parrt --version`: the package version, the git commit it was
//! built from (when known at build time), the cargo profile and the target. `master/build.rs`
//! records them; this is the one place the text is put together, so later facts about the build
//! (the instruction-set tier, from `parrt::isa`) join it here.

use std::sync::OnceLock;

/// The facts `--version` prints.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BuildInfo {
    /// The package version (`Cargo.toml`).
    pub version: &'static str,
    /// The git commit, abbreviated; `None` when built outside a git checkout or without git.
    pub commit: Option<&'static str>,
    /// The cargo profile's base (`release` or `debug`; tests and benches build on these).
    pub profile: &'static str,
    /// The target triple.
    pub target: &'static str,
    /// The instruction-set tier this process runs (`PARRT_ISA`, else the best the CPU has).
    pub isa: &'static str,
}

impl BuildInfo {
    /// This binary's build.
    pub fn current() -> BuildInfo {
        let commit = env!("PARRT_BUILD_COMMIT");
        BuildInfo {
            version: env!("CARGO_PKG_VERSION"),
            commit: (!commit.is_empty()).then_some(commit),
            profile: env!("PARRT_BUILD_PROFILE"),
            target: env!("PARRT_BUILD_TARGET"),
            isa: parrt::isa::current().name(),
        }
    }

    /// One line: `0.1.0 (commit 1a2b3c4d5e, release build, x86_64-unknown-linux-gnu, tier avx2)`.
    pub fn text(&self) -> String {
        let commit = match self.commit {
            Some(c) => format!("commit {c}"),
            None => "commit unknown".to_string(),
        };
        format!(
            "{} ({commit}, {} build, {}, tier {})",
            self.version, self.profile, self.target, self.isa
        )
    }
}

/// The version text clap prints for `parrt --version` (and every subcommand's), made once.
pub fn text() -> &'static str {
    static TEXT: OnceLock<String> = OnceLock::new();
    TEXT.get_or_init(|| BuildInfo::current().text())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_names_version_commit_profile_and_target() {
        let b = BuildInfo {
            version: "1.2.3",
            commit: Some("abcdef1234"),
            profile: "release",
            target: "x86_64-unknown-linux-gnu",
            isa: "avx2",
        };
        assert_eq!(
            b.text(),
            "1.2.3 (commit abcdef1234, release build, x86_64-unknown-linux-gnu, tier avx2)"
        );
        let outside_git = BuildInfo { commit: None, ..b };
        assert!(outside_git.text().contains("commit unknown"));
    }

    #[test]
    fn this_build_knows_its_profile_and_target() {
        let b = BuildInfo::current();
        assert_eq!(b.version, env!("CARGO_PKG_VERSION"));
        assert!(b.profile == "debug" || b.profile == "release", "{b:?}");
        assert!(!b.target.is_empty());
    }
}
