//! `docs/reference/cli.md` is the reference generated from the clap definitions: every flag of
//! every subcommand appears there as `--help` states it. With `JK_WRITE_CLI_REFERENCE=1` the
//! test writes the page instead of failing.

use std::path::Path;

#[test]
fn the_cli_reference_page_is_generated_from_the_flags() {
    let page = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/reference/cli.md");
    let generated = host::cli::reference::markdown();
    if std::env::var_os("JK_WRITE_CLI_REFERENCE").is_some() {
        std::fs::write(&page, &generated).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&page).unwrap_or_default();
    assert!(
        committed == generated,
        "{} is not the reference the flags generate; regenerate it with \
         JK_WRITE_CLI_REFERENCE=1 cargo test --release -p host --test cli_reference",
        page.display()
    );
}

/// The generator sees every flag: a few flags of each subcommand, and the subcommands of
/// `host study`, are on the page.
#[test]
fn the_reference_names_every_subcommand_and_their_flags() {
    let page = host::cli::reference::markdown();
    for part in [
        "## `host render`",
        "## `host eval`",
        "## `host bench`",
        "## `host report`",
        "## `host probe`",
        "## `host study`",
        "## `host study table1`",
        "`--backend <BACKEND>`",
        "`--estimators <ESTIMATORS>`",
        "`--reference-spp <REFERENCE_SPP>`",
        "`--sweep`",
        "`--from-eval <DIR>`",
        "`--restir-passes",
    ] {
        assert!(
            page.contains(part),
            "{part:?} missing from the generated reference"
        );
    }
    // Accepted values are listed with their help.
    assert!(
        page.contains("`auto` (") && page.contains("`cpu` ("),
        "{page}"
    );
}
