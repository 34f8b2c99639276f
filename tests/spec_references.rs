//! Every section reference (the section sign followed by a number, as in "spec" + sign +
//! "7.3") in the repository's code, scripts and Markdown names a numbered heading of the
//! algorithm reference, `docs/algorithms.md`.
//!
//! Conventions the check applies (stated at the top of `docs/algorithms.md`):
//! - a section is a Markdown heading that starts with its number: `## 7. IWFQI …` is
//!   section 7, `### 7.3 Weight estimators` section 7.3, `### 14.7 GP noise subtraction`
//!   section 14.7 (the numbered items of section 14 are headings 14.1, 14.2, …); a
//!   reference to section 14 followed by "item 7" means section 14.7;
//! - a reference attributed to the thesis or to a paper is not ours and is skipped: the word
//!   right before the sign is "thesis" or "paper" (possibly at the end of the previous
//!   line), and a reference that continues such a one in a range or list (the thesis's
//!   sections 4.1 to 4.3 written as a range) is skipped with it;
//! - a sign not followed by a number is prose, not a reference.
//!
//! The files scanned: `.rs`, `.md`, `.toml`, `.py` and `.sh` files and extensionless scripts
//! (a `#!` first line), outside `.git`, build outputs (`target`), experiment outputs
//! (`results`) and fuzzing corpora. This file writes the sign only as `\u{a7}` (and `$` in
//! its synthetic examples), so it holds no reference itself.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

/// The section sign.
const SIGN: char = '\u{a7}';

/// The algorithm reference, relative to the repository root.
const REFERENCE: &str = "docs/algorithms.md";

/// One section reference found in a text.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Reference {
    /// 1-based line number.
    line: usize,
    /// The section number, e.g. "7.3".
    section: String,
    /// Attributed to the thesis or a paper (not checked).
    external: bool,
}

/// The section number at the start of `text` ("14.7" of "14.7 GP…", "7" of "7. IWFQI";
/// a trailing dot is not part of it) and the number of bytes it takes.
fn leading_number(text: &str) -> Option<(String, usize)> {
    let bytes = text.as_bytes();
    let digits = |from: usize| {
        bytes
            .get(from..)
            .map_or(0, |b| b.iter().take_while(|c| c.is_ascii_digit()).count())
    };
    let mut end = digits(0);
    if end == 0 {
        return None;
    }
    while bytes.get(end) == Some(&b'.') && digits(end + 1) > 0 {
        end += 1 + digits(end + 1);
    }
    Some((text[..end].to_string(), end))
}

/// The numbers of the numbered headings of a Markdown document, in order (headings inside
/// fenced code blocks are not headings).
fn headings(doc: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_code = false;
    for line in doc.lines() {
        let t = line.trim_start();
        if t.starts_with("```") {
            in_code = !in_code;
            continue;
        }
        let level = t.chars().take_while(|&c| c == '#').count();
        if in_code || level == 0 || level > 6 || !t[level..].starts_with(' ') {
            continue;
        }
        if let Some((number, _)) = leading_number(t[level..].trim_start()) {
            out.push(number);
        }
    }
    out
}

/// `line` without leading whitespace and comment or list markers (`//!`, `///`, `//`, `#`,
/// `*`, `>`, `-`).
fn strip_markers(line: &str) -> &str {
    let mut t = line.trim_start();
    loop {
        let before = t;
        for marker in ["//!", "///", "//", "#", "*", ">", "-"] {
            if let Some(rest) = t.strip_prefix(marker) {
                t = rest.trim_start();
            }
        }
        if t == before {
            return t;
        }
    }
}

/// The last word of `text` (letters, digits, apostrophes), lower-cased, ignoring trailing
/// whitespace and opening brackets or emphasis.
fn last_word(text: &str) -> String {
    let t = text.trim_end_matches(|c: char| c.is_whitespace() || "([*_`".contains(c));
    let start = t
        .char_indices()
        .rev()
        .take_while(|&(_, c)| c.is_alphanumeric() || c == '\'' || c == '\u{2019}')
        .last()
        .map_or(t.len(), |(i, _)| i);
    t[start..].to_lowercase().replace('\u{2019}', "'")
}

/// `true` when `between` (the text from the end of one reference to the next sign) only
/// joins two references in a range or list: dashes, commas, slashes, "and", "or", "to"
/// (a semicolon ends the list).
fn only_connectors(between: &str) -> bool {
    between
        .split(|c: char| c.is_whitespace() || "–—-,/&".contains(c))
        .all(|w| matches!(w, "" | "and" | "or" | "to"))
}

/// Whether a word before a sign attributes the reference to someone else's document.
fn is_external_word(word: &str) -> bool {
    matches!(word, "thesis" | "thesis's" | "paper" | "paper's")
}

/// Every section reference of `text`, with its attribution.
fn references(text: &str) -> Vec<Reference> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out: Vec<Reference> = Vec::new();
    // (line index, byte end, external) of the previous reference.
    let mut previous: Option<(usize, usize, bool)> = None;
    for (i, line) in lines.iter().enumerate() {
        for (pos, _) in line.match_indices(SIGN) {
            let after = &line[pos + SIGN.len_utf8()..];
            let skipped = after.len() - after.trim_start().len();
            let Some((mut section, len)) = leading_number(after.trim_start()) else {
                continue;
            };
            let end = pos + SIGN.len_utf8() + skipped + len;
            // A reference to section 14 followed by "item 7" is section 14.7.
            let rest = &line[end..];
            if !section.contains('.') {
                if let Some(item) = rest.trim_start().strip_prefix("item ") {
                    if let Some((n, _)) = leading_number(item) {
                        section = format!("{section}.{n}");
                    }
                }
            }
            let before = &line[..pos];
            let chained = match previous {
                Some((l, e, ext)) if l == i => only_connectors(&line[e..pos]).then_some(ext),
                Some((l, e, ext)) if l + 1 == i => {
                    let tail = &lines[l][e..];
                    (only_connectors(tail) && only_connectors(strip_markers(before))).then_some(ext)
                }
                _ => None,
            };
            let external = chained.unwrap_or_else(|| {
                let mut lead = strip_markers(before).to_string();
                if last_word(&lead).is_empty() && lead.trim().chars().all(|c| "([*_`".contains(c)) {
                    if let Some(prev) = i.checked_sub(1).and_then(|p| lines.get(p)) {
                        lead = format!("{prev} {lead}");
                    }
                }
                is_external_word(&last_word(&lead))
            });
            out.push(Reference {
                line: i + 1,
                section,
                external,
            });
            previous = Some((i, end, external));
        }
    }
    out
}

/// The outcome of checking files against a set of sections.
#[derive(Debug, Default)]
struct Report {
    /// References checked (not external).
    checked: usize,
    /// References skipped as the thesis's or a paper's.
    external: usize,
    /// `path:line: <sign>N` of every reference to a section that does not exist.
    missing: Vec<String>,
}

/// Checks the references of `files` (name, text) against `sections`.
fn check<'a>(
    sections: &BTreeSet<String>,
    files: impl IntoIterator<Item = (&'a str, &'a str)>,
) -> Report {
    let mut report = Report::default();
    for (name, text) in files {
        for r in references(text) {
            if r.external {
                report.external += 1;
            } else {
                report.checked += 1;
                if !sections.contains(&r.section) {
                    report
                        .missing
                        .push(format!("{name}:{}: {SIGN}{}", r.line, r.section));
                }
            }
        }
    }
    report
}

/// Directories never scanned: version control, build and experiment outputs, fuzz corpora.
fn skipped_dir(name: &str) -> bool {
    matches!(
        name,
        ".git" | "target" | "results" | "corpus" | "artifacts" | "node_modules"
    ) || (name.starts_with('.') && name != ".ci")
}

/// The text files of the repository that can hold references (see the module docs), with
/// their contents.
fn scanned_files(root: &Path) -> Vec<(PathBuf, String)> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let mut entries: Vec<_> = fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
            .map(|e| e.expect("directory entry").path())
            .collect();
        entries.sort();
        for path in entries {
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if path.is_dir() {
                if !skipped_dir(name) {
                    stack.push(path);
                }
                continue;
            }
            let ext = path.extension().and_then(|e| e.to_str());
            let wanted = matches!(ext, Some("rs" | "md" | "toml" | "py" | "sh")) || ext.is_none();
            if !wanted {
                continue;
            }
            let Ok(text) = fs::read_to_string(&path) else {
                continue; // not UTF-8: not a source file
            };
            if ext.is_none() && !text.starts_with("#!") {
                continue; // extensionless but not a script (e.g. a fuzz seed)
            }
            let relative = path.strip_prefix(root).unwrap_or(&path).to_path_buf();
            out.push((relative, text));
        }
    }
    out.sort();
    out
}

#[test]
fn every_section_reference_names_a_section_of_the_algorithm_reference() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = fs::read_to_string(root.join(REFERENCE))
        .unwrap_or_else(|e| panic!("{REFERENCE} must exist: {e}"));
    let sections: BTreeSet<String> = headings(&doc).into_iter().collect();
    let files = scanned_files(root);
    let names: Vec<String> = files
        .iter()
        .map(|(p, _)| p.to_string_lossy().replace('\\', "/"))
        .collect();
    // The walk really saw the repository (a walk that found nothing would pass vacuously).
    for expected in [
        "README.md",
        "src/thesis.rs",
        "std_harness/src/forest_fqi.rs",
        REFERENCE,
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "{expected} not scanned"
        );
    }
    let report = check(
        &sections,
        names
            .iter()
            .zip(&files)
            .map(|(n, (_, text))| (n.as_str(), text.as_str())),
    );
    println!(
        "{} section references checked in {} files against {} sections of {REFERENCE}; \
         {} attributed to the thesis or a paper skipped",
        report.checked,
        files.len(),
        sections.len(),
        report.external
    );
    assert!(report.checked > 0, "no section reference found at all");
    assert!(
        report.missing.is_empty(),
        "{} section reference(s) name a section that {REFERENCE} does not have:\n{}",
        report.missing.len(),
        report.missing.join("\n")
    );
}

#[test]
fn the_algorithm_reference_numbers_each_section_once_and_in_order() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let doc = fs::read_to_string(root.join(REFERENCE)).expect("the algorithm reference");
    let numbers = headings(&doc);
    let key = |s: &str| -> Vec<u32> { s.split('.').map(|p| p.parse().expect("digits")).collect() };
    for pair in numbers.windows(2) {
        assert!(
            key(&pair[0]) < key(&pair[1]),
            "heading {} follows {}: numbers must be unique and increasing",
            pair[1],
            pair[0]
        );
    }
}

// ---- The checker on small synthetic inputs: it must be able to fail. ----

/// `s` with every `$` replaced by the section sign (the sign is not written in this file).
fn signed(s: &str) -> String {
    s.replace('$', &SIGN.to_string())
}

#[test]
fn headings_give_their_leading_numbers_only() {
    let doc = "# Title 3\n## 1. Conventions\n### 2.1 Constants (thesis 4.1)\n\
               ```\n## 9. not a heading\n```\n#### 14.7 GP noise\n##5 no space\n\
               Text 6.1\n## Unnumbered\n";
    assert_eq!(headings(doc), ["1", "2.1", "14.7"]);
}

#[test]
fn references_are_found_with_their_attribution() {
    let text = signed(
        "//! spec $2.1 and $2.2–$2.3, also $3.\n\
         /// (thesis $4.1.1) then the thesis's $4.3 and (spec $10, thesis $4.1)\n\
         //! study of spec $10.4 (thesis\n\
         //! $4.1.5, Figs. 4.2)\n\
         paper $5–$6; $14 item 7, $ alone, $x\n\
         (thesis $3–\n\
         $9) and spec $2\n",
    );
    let got: Vec<(usize, String, bool)> = references(&text)
        .into_iter()
        .map(|r| (r.line, r.section, r.external))
        .collect();
    let want: Vec<(usize, String, bool)> = [
        (1, "2.1", false),
        (1, "2.2", false),
        (1, "2.3", false),
        (1, "3", false),
        (2, "4.1.1", true),
        (2, "4.3", true),
        (2, "10", false),
        (2, "4.1", true),
        (3, "10.4", false),
        (4, "4.1.5", true),
        (5, "5", true),
        (5, "6", true),
        (5, "14.7", false),
        (6, "3", true),
        (7, "9", true),
        (7, "2", false),
    ]
    .into_iter()
    .map(|(l, s, e)| (l, s.to_string(), e))
    .collect();
    assert_eq!(got, want);
}

#[test]
fn the_check_names_every_unresolved_reference_by_file_and_line() {
    let doc = "## 1. One\n### 1.1 Sub\n## 2. Two\n### 14.7 Item\n";
    let sections: BTreeSet<String> = headings(doc).into_iter().collect();
    let a = signed("fine: $1, $1.1 and $2\nmissing: $1.2\n");
    let b = signed("thesis $9.9 is skipped\n$14 item 7 resolves, $14 item 8 does not\n$3.1\n");
    let report = check(&sections, [("a.rs", a.as_str()), ("b.md", b.as_str())]);
    assert_eq!(report.checked, 7);
    assert_eq!(report.external, 1);
    let sign = SIGN;
    assert_eq!(
        report.missing,
        [
            format!("a.rs:2: {sign}1.2"),
            format!("b.md:2: {sign}14.8"),
            format!("b.md:3: {sign}3.1"),
        ]
    );
}
