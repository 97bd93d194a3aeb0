//! Records the git revision the package was built from (for the trial
//! manifest), as the CLI does; "unknown" outside a git checkout.

fn main() {
    abba_build_info::emit_git_revision();
}
