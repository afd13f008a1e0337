//! The docs against what they describe: the task lines of docs/ARCHITECTURE.md against the
//! host's task declaration (`tetradrill::tasks::TASKS`), the host crate's module table against
//! its modules, README's layout against the workspace's folders, the core's layer rule against
//! its `crate::` paths, and no comment or doc citing a file the repository does not hold.
//!
//! Each check reads the files as text, with its own small parser: nothing here shares code
//! with what it checks.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use tetradrill::tasks::TASKS;
use tetradrill_tests::workspace_root;

fn read(rel: &str) -> String {
    let path = workspace_root().join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The cells of the first Markdown table after the heading `heading` (header and separator
/// rows left out), each row's cells trimmed.
fn table_after(text: &str, heading: &str) -> Vec<Vec<String>> {
    let at = text
        .find(heading)
        .unwrap_or_else(|| panic!("no heading {heading:?}"));
    let section = &text[at + heading.len()..];
    let section = section.split("\n## ").next().unwrap_or_default();
    let rows: Vec<&str> = section
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .collect();
    assert!(rows.len() >= 2, "no table under {heading:?}");
    rows[2..]
        .iter()
        .map(|r| {
            r.trim()
                .trim_start_matches('|')
                .trim_end_matches('|')
                .split(" | ")
                .map(|c| c.trim().to_string())
                .collect()
        })
        .collect()
}

#[test]
fn the_architecture_task_lines_are_the_declared_tasks() {
    let doc = table_after(&read("docs/ARCHITECTURE.md"), "## Tasks and hand-offs");
    let code: Vec<Vec<String>> = TASKS
        .iter()
        .map(|t| {
            [t.name, t.priority, t.period, t.does]
                .iter()
                .map(|s| s.to_string())
                .collect()
        })
        .collect();
    for (i, (d, c)) in doc.iter().zip(&code).enumerate() {
        assert_eq!(
            d,
            c,
            "docs/ARCHITECTURE.md task line {} against TASKS[{i}]",
            i + 1
        );
    }
    assert_eq!(
        doc.len(),
        code.len(),
        "docs/ARCHITECTURE.md has {} task lines, TASKS {} tasks",
        doc.len(),
        code.len()
    );
    let names: BTreeSet<&str> = TASKS.iter().map(|t| t.name).collect();
    assert_eq!(names.len(), TASKS.len(), "two tasks share a name");
}

/// Every Markdown file and Rust source of the workspace (no build folders, no hidden ones).
fn text_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') || name == "target" {
            continue;
        }
        if p.is_dir() {
            text_files(&p, out);
        } else if ["rs", "md", "toml"]
            .iter()
            .any(|x| p.extension().is_some_and(|e| e == *x))
        {
            out.push(p);
        }
    }
}

#[test]
fn no_other_doc_copies_the_task_table() {
    let root = workspace_root();
    let mut files = Vec::new();
    text_files(&root, &mut files);
    let architecture = root.join("docs/ARCHITECTURE.md");
    for f in files.iter().filter(|f| **f != architecture) {
        let text = std::fs::read_to_string(f).unwrap_or_default();
        for (n, line) in text.lines().enumerate() {
            let cells = line.trim_start().trim_start_matches("//!").trim_start();
            for t in &TASKS {
                let row = format!("| {} ", t.name);
                assert!(
                    !(cells.starts_with(&row) && cells.contains(t.period)),
                    "{}:{}: a copy of the task table's {} line; docs/ARCHITECTURE.md has the \
                     one checked copy",
                    f.display(),
                    n + 1,
                    t.name
                );
            }
        }
    }
}

#[test]
fn the_host_module_table_lists_every_module() {
    let lib = read("host-runner/src/lib.rs");
    let mut modules = BTreeSet::new();
    for line in lib.lines() {
        if let Some(m) = line.strip_prefix("pub mod ") {
            modules.insert(m.trim_end_matches([';', '{', ' ']).to_string());
        } else if let Some(u) = line.strip_prefix("pub use ") {
            // A re-exported crate or module (`pub use X as NAME;`, `pub use a::NAME;` of a
            // lower-case name); re-exported items (`Error`, `{Drilling, ..}`) are not modules.
            let u = u.trim_end_matches(';');
            let name = u.rsplit([' ', ':']).next().unwrap_or(u);
            if name.starts_with(|c: char| c.is_ascii_lowercase()) && !u.contains('{') {
                modules.insert(name.to_string());
            }
        }
    }
    let mut listed = Vec::new();
    for line in lib.lines() {
        if let Some(row) = line.strip_prefix("//! | [`") {
            listed.push(row.split('`').next().unwrap_or_default().to_string());
        }
    }
    let listed_set: BTreeSet<String> = listed.iter().cloned().collect();
    assert_eq!(
        listed.len(),
        listed_set.len(),
        "a module listed twice: {listed:?}"
    );
    assert_eq!(
        listed_set, modules,
        "host-runner/src/lib.rs: the module table against the modules"
    );
}

#[test]
fn the_readme_layout_names_every_folder() {
    let readme = read("README.md");
    let at = readme
        .find("## Layout")
        .expect("README has a Layout section");
    let block = readme[at..]
        .split("```")
        .nth(1)
        .expect("the Layout section has a code block");
    let named: BTreeSet<String> = block
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter_map(|w| w.strip_suffix('/'))
        .map(str::to_string)
        .collect();
    // The folders the repository holds (git's, when this is a clone: a user's own untracked
    // folder beside them is not the project's), else the folders on disk.
    let tracked = std::process::Command::new("git")
        .args(["ls-tree", "-d", "--name-only", "HEAD"])
        .current_dir(workspace_root())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned());
    let folders: BTreeSet<String> = match tracked {
        Some(list) => list
            .lines()
            .filter(|n| !n.starts_with('.'))
            .map(str::to_string)
            .collect(),
        None => std::fs::read_dir(workspace_root())
            .expect("workspace root")
            .flatten()
            .filter(|e| e.path().is_dir())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| !n.starts_with('.') && n != "target")
            .collect(),
    };
    assert_eq!(
        named, folders,
        "README.md's Layout against the workspace's folders"
    );
}

/// The names after `crate::` in `code` (comments already taken out): `crate::a::b` gives `a`,
/// `crate::{a, b::c}` gives `a` and `b`.
fn crate_paths(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    for (i, _) in code.match_indices("crate::") {
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // Top-level names of the brace group.
            let mut depth = 0;
            let mut start = true;
            for (j, ch) in group.char_indices() {
                match ch {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => start = true,
                    c if start && !c.is_whitespace() => {
                        out.insert(ident(&group[j..]));
                        start = false;
                    }
                    _ => {}
                }
            }
        } else {
            out.insert(ident(rest));
        }
    }
    out
}

#[test]
fn the_core_layers_never_use_a_higher_one() {
    let src = workspace_root().join("core-nostd/src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).expect("core lib.rs");
    // The layer map, lowest first: the rows `//! | [`name`] | ... |`.
    let order: Vec<String> = lib
        .lines()
        .filter_map(|l| l.strip_prefix("//! | [`"))
        .map(|r| r.split('`').next().unwrap_or_default().to_string())
        .collect();
    assert!(order.len() >= 10, "the core's layer map: {order:?}");
    let rank = |m: &str| order.iter().position(|o| o == m);
    let mut files = Vec::new();
    text_files(&src, &mut files);
    let mut upward = Vec::new();
    for f in files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "rs"))
    {
        let rel = f.strip_prefix(&src).expect("below src");
        let first = rel.components().next().expect("a path");
        let module = first.as_os_str().to_string_lossy();
        let module = module.trim_end_matches(".rs");
        let Some(own) = rank(module) else {
            continue;
        };
        let text = std::fs::read_to_string(f).expect("source");
        let code: String = text
            .lines()
            .map(|l| l.split("//").next().unwrap_or_default())
            .collect::<Vec<_>>()
            .join("\n");
        for used in crate_paths(&code) {
            if rank(&used).is_some_and(|r| r > own) {
                upward.push(format!("{} uses crate::{used}", rel.display()));
            }
        }
    }
    assert!(
        upward.is_empty(),
        "lower layers use higher ones (core-nostd/src/lib.rs's layer map): {upward:#?}"
    );
}

#[test]
fn the_layer_check_sees_an_upward_use() {
    // The check's parser on its own: a path, a brace group, a nested group.
    let found = crate_paths("use crate::force::x;\nuse crate::{geom, mesh::{a, b}};");
    let want: BTreeSet<String> = ["force", "geom", "mesh"].map(String::from).into();
    assert_eq!(found, want);
}

#[test]
fn no_comment_or_doc_cites_a_file_outside_the_repository() {
    let root = workspace_root();
    let mut files = Vec::new();
    text_files(&root, &mut files);
    // Built from parts, so this file does not match itself.
    let outside = [
        ["seed", " 00"].concat(),
        ["Seed", " 00"].concat(),
        ["DESIGN", ".md"].concat(),
        ["DESIGN", " section"].concat(),
        ["DESIGN", " 2."].concat(),
        ["STYLE", ".md"].concat(),
        ["../", "shared"].concat(),
    ];
    let mut found = Vec::new();
    for f in &files {
        // The changelog is history: it may name what the project once cited.
        if f.ends_with("CHANGELOG.md") {
            continue;
        }
        let text = std::fs::read_to_string(f).unwrap_or_default();
        for (n, line) in text.lines().enumerate() {
            if outside.iter().any(|p| line.contains(p.as_str())) {
                found.push(format!("{}:{}: {}", f.display(), n + 1, line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "cite the works by name (docs/REFERENCES.md), not files beside the repository: \
         {found:#?}"
    );
}

/// No Rust source of the workspace, the firmware or the fuzz targets is over 800 lines: a file
/// that grows past it is split by concept.
#[test]
fn no_source_file_is_over_800_lines() {
    let mut files = Vec::new();
    text_files(&workspace_root(), &mut files);
    let long: Vec<String> = files
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .filter_map(|p| {
            let n = std::fs::read_to_string(p).ok()?.lines().count();
            (n > 800).then(|| format!("{} ({n} lines)", p.display()))
        })
        .collect();
    assert!(long.is_empty(), "over 800 lines: {long:?}");
}
