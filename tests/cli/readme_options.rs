//! README.md's documentation stays current: every option of every subcommand is mentioned.

use clap::CommandFactory;
use realcam::cli::Cli;

#[test]
fn the_readme_mentions_every_option_of_every_subcommand() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let mentioned = |option: &str| {
        readme.match_indices(option).any(|(at, _)| {
            // `--exr` must not count as a mention of `--exr-foo`.
            readme[at + option.len()..]
                .chars()
                .next()
                .is_none_or(|c| !(c.is_ascii_alphanumeric() || c == '-'))
        })
    };
    let mut missing = Vec::new();
    let mut checked = 0;
    for subcommand in Cli::command().get_subcommands() {
        for arg in subcommand.get_arguments() {
            if let Some(long) = arg.get_long() {
                checked += 1;
                let option = format!("--{long}");
                if !mentioned(&option) {
                    missing.push(format!("realcam {} {option}", subcommand.get_name()));
                }
            }
        }
    }
    assert!(checked > 50, "only {checked} options found");
    assert!(
        missing.is_empty(),
        "README.md does not mention: {missing:?}"
    );
}
