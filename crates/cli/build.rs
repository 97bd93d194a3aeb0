//! Records the git revision the binary was built from (for the trial
//! manifest); "unknown" outside a git checkout.

fn main() {
    abba_build_info::emit_git_revision();
}
