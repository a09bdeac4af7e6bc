//! What build a binary is, for `--version`: the package version, the git commit it was built
//! from (when known at build time), the cargo profile, the target and the instruction-set tier
//! this process runs. The one place the text is put together, for both `parrt` and
//! `parrt-worker`; the facts known at build time come from the binary's own package (its build
//! script, `master/build.rs`, which the worker package runs too) through [`crate::build_info!`].
//! Never reads anything but compile-time constants and the process's tier.

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
    /// The build facts a build script recorded (an empty `commit` means unknown), with the tier
    /// this process runs. Call it through [`crate::build_info!`], which reads the calling
    /// package's constants.
    pub fn new(
        version: &'static str,
        commit: &'static str,
        profile: &'static str,
        target: &'static str,
    ) -> BuildInfo {
        BuildInfo {
            version,
            commit: (!commit.is_empty()).then_some(commit),
            profile,
            target,
            isa: crate::isa::current().name(),
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

/// The calling package's [`BuildInfo`](crate::build_info::BuildInfo): its version and what its
/// build script (`master/build.rs`) recorded in `PARRT_BUILD_COMMIT`, `PARRT_BUILD_PROFILE` and
/// `PARRT_BUILD_TARGET`. A macro so that `env!` reads the caller's constants, not this library's.
#[macro_export]
macro_rules! build_info {
    () => {
        $crate::build_info::BuildInfo::new(
            env!("CARGO_PKG_VERSION"),
            env!("PARRT_BUILD_COMMIT"),
            env!("PARRT_BUILD_PROFILE"),
            env!("PARRT_BUILD_TARGET"),
        )
    };
}

/// The calling package's `--version` text ([`build_info!`](crate::build_info!)`.text()`), made
/// once per call site, as a `&'static str` for clap's `#[command(version = …)]`.
#[macro_export]
macro_rules! version_text {
    () => {{
        static TEXT: ::std::sync::OnceLock<::std::string::String> = ::std::sync::OnceLock::new();
        TEXT.get_or_init(|| $crate::build_info!().text()).as_str()
    }};
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_names_version_commit_profile_target_and_tier() {
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
    fn an_empty_commit_is_unknown_and_the_tier_is_this_process() {
        let b = BuildInfo::new("0.1.0", "", "debug", "x86_64-unknown-linux-gnu");
        assert_eq!(b.commit, None);
        assert_eq!(b.isa, crate::isa::current().name());
        assert_eq!(
            BuildInfo::new("0.1.0", "abc", "debug", "t").commit,
            Some("abc")
        );
    }
}
