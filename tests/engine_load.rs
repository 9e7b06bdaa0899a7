//! Loading and validation: every kind of problem in a pipeline file is reported, all at once,
//! with its kind and line.

mod common;

use common::*;
use crestflow_flow::{load, load_file, parse_set, parse_set_for, DiagKind, Graph, LoadError};

fn load_err(text: &str) -> LoadError {
    let dir = tempdir();
    let p = write(dir.path(), "g.ron", text);
    match load_file(&p, &toy_registry(), &[]) {
        Ok(_) => panic!("graph loaded but should not"),
        Err(e) => e,
    }
}

/// The (kind, line) pairs of an error, in source order.
fn kinds_lines(e: &LoadError) -> Vec<(DiagKind, usize)> {
    e.diagnostics.iter().map(|d| (d.kind, d.line)).collect()
}

#[test]
fn a_good_graph_loads_and_plans_in_dependency_order() {
    let dir = tempdir();
    let p = write(
        dir.path(),
        "g.ron",
        r#"Graph(
    params: { "v": 2.5 },
    nodes: {
        "sum": (kind: "toy.add", inputs: { "a": "c.value", "b": "d.value" }),
        "c": (kind: "toy.const", params: (value: "$v")),
        "d": (kind: "toy.const"),
    },
)"#,
    );
    let reg = toy_registry();
    let plan = load_file(&p, &reg, &[]).unwrap();
    let names: Vec<&str> = plan
        .order
        .iter()
        .map(|&i| plan.nodes[i].name.as_str())
        .collect();
    assert_eq!(names, ["c", "d", "sum"]);
    // `$v` as a whole string inserts the RON value: the number stays a number.
    assert_eq!(plan.nodes[1].params.canonical, "(value:2.5)");
    assert_eq!(plan.stages().len(), 2);
    assert!(plan.explain().contains("sum [toy.add v1]"));
    assert!(plan.to_dot().contains("\"c\" -> \"sum\""));
    assert!(plan.to_mermaid().contains("n1 -->"));
}

#[test]
fn syntax_error_has_its_line() {
    let e = load_err("Graph(\n  nodes: {\n    \"a\": (kind: \"toy.const\"\n  },\n)");
    assert_eq!(kinds_lines(&e), vec![(DiagKind::Syntax, 4)]);
}

#[test]
fn unknown_kind_with_did_you_mean() {
    let e = load_err("Graph(nodes: {\n \"a\": (kind: \"toy.cosnt\"),\n})");
    assert_eq!(kinds_lines(&e), vec![(DiagKind::UnknownKind, 2)]);
    assert_eq!(
        e.diagnostics[0].help.as_deref(),
        Some("did you mean `toy.const`?")
    );
    assert_eq!(e.diagnostics[0].column, 14);
}

#[test]
fn unknown_mistyped_and_out_of_range_params() {
    let e = load_err(
        r#"Graph(nodes: {
  "a": (kind: "toy.const", params: (valeu: 1.0)),
  "b": (kind: "toy.const", params: (value: "one")),
  "c": (kind: "toy.add", params: (
         offset: 5000.0), inputs: { "a": "b.value" }),
})"#,
    );
    assert_eq!(
        kinds_lines(&e),
        vec![
            (DiagKind::UnknownParam, 2),
            (DiagKind::BadParam, 3),
            (DiagKind::InvalidParam, 5)
        ]
    );
    // The unknown field is pointed at precisely.
    assert_eq!(e.diagnostics[0].column, 37);
    assert!(
        e.diagnostics[2].message.contains("offset"),
        "{}",
        e.diagnostics[2].message
    );
}

#[test]
fn unknown_ports_type_mismatch_missing_input() {
    let e = load_err(
        r#"Graph(nodes: {
  "c": (kind: "toy.const"),
  "f": (kind: "toy.read_file", params: (path: "x")),
  "a": (kind: "toy.add", inputs: { "aa": "c.value" }),
  "b": (kind: "toy.add", inputs: { "a": "c.valeu" }),
  "t": (kind: "toy.add", inputs: { "a": "f.bytes" }),
  "u": (kind: "toy.add", inputs: { "a": "nope.value" }),
})"#,
    );
    assert_eq!(
        kinds_lines(&e),
        vec![
            (DiagKind::MissingInput, 4),
            (DiagKind::UnknownPort, 4),
            (DiagKind::UnknownPort, 5),
            (DiagKind::TypeMismatch, 6),
            (DiagKind::UnknownNode, 7),
        ]
    );
    let tm = &e.of(DiagKind::TypeMismatch)[0].message;
    assert!(
        tm.starts_with("toy.add.a expects f64, got Vec<u8> from f.bytes"),
        "{tm}"
    );
    assert_eq!(
        e.of(DiagKind::UnknownPort)[1].help.as_deref(),
        Some("did you mean `value`?")
    );
}

#[test]
fn cycle_names_its_nodes() {
    let e = load_err(
        r#"Graph(nodes: {
  "a": (kind: "toy.add", inputs: { "a": "c.sum" }),
  "b": (kind: "toy.add", inputs: { "a": "a.sum" }),
  "c": (kind: "toy.add", inputs: { "a": "b.sum" }),
  "d": (kind: "toy.const"),
})"#,
    );
    assert_eq!(kinds_lines(&e), vec![(DiagKind::Cycle, 2)]);
    assert!(
        e.diagnostics[0].message.contains("a -> b -> c"),
        "{}",
        e.diagnostics[0].message
    );
}

#[test]
fn duplicate_node_names_are_detected_in_the_source() {
    let e = load_err(
        r#"Graph(nodes: {
  "a": (kind: "toy.const"),
  "a": (kind: "toy.const", params: (value: 2.0)),
})"#,
    );
    assert_eq!(kinds_lines(&e), vec![(DiagKind::Duplicate, 3)]);
}

#[test]
fn undefined_param_and_all_problems_at_once() {
    let e = load_err(
        r#"Graph(
  params: { "x": 1.0 },
  nodes: {
    "a": (kind: "toy.const", params: (value: "$y")),
    "b": (kind: "toy.nope"),
    "c": (kind: "toy.read_file", params: (path: "${x}/and/${z}.txt")),
  },
)"#,
    );
    assert_eq!(
        kinds_lines(&e),
        vec![
            (DiagKind::UndefinedVar, 4),
            (DiagKind::UnknownKind, 5),
            (DiagKind::UndefinedVar, 6)
        ]
    );
    assert!(e.diagnostics[0].message.contains("`$y`"));
    assert!(e.diagnostics[2].message.contains("`$z`"));
    // The Display form is file:line:column: message.
    let text = e.to_string();
    assert!(
        text.contains("g.ron:4:46: node `a`: `$y` is not a graph param"),
        "{text}"
    );
}

#[test]
fn interpolation_and_set_overrides() {
    let dir = tempdir();
    let p = write(
        dir.path(),
        "g.ron",
        r#"Graph(
  params: { "name": "mesh", "n": 3 },
  nodes: { "r": (kind: "toy.read_file", params: (path: "data/${name}_$n.txt $$5")) },
)"#,
    );
    let reg = toy_registry();
    let plan = load_file(&p, &reg, &[]).unwrap();
    assert_eq!(
        plan.nodes[0].params.canonical,
        r#"(path:"data/mesh_3.txt $5")"#
    );
    let set = parse_set("n=7", dir.path()).unwrap();
    assert_eq!(set, ("n".to_string(), "7".to_string()));
    let plan = load_file(&p, &reg, &[set, ("name".into(), "\"x\"".into())]).unwrap();
    assert_eq!(
        plan.nodes[0].params.canonical,
        r#"(path:"data/x_7.txt $5")"#
    );
    // An override of a param the graph does not declare is an error.
    let e = match load_file(&p, &reg, &[("nmae".into(), "1".into())]) {
        Err(e) => e,
        Ok(_) => panic!("should not load"),
    };
    assert!(e.has(DiagKind::UnknownGraphParam));
}

#[test]
fn set_values_that_are_relative_paths_become_absolute() {
    let dir = tempdir();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    write(dir.path(), "in.off", "");
    let abs = |s: &str| crestflow_flow::spanned::quote(&dir.path().join(s).to_string_lossy());
    assert_eq!(
        parse_set("mesh=in.off", dir.path()).unwrap().1,
        abs("in.off")
    );
    assert_eq!(
        parse_set("out=sub/new.ply", dir.path()).unwrap().1,
        abs("sub/new.ply")
    );
    // Words that are not paths stay strings; numbers stay numbers.
    assert_eq!(parse_set("method=fast", dir.path()).unwrap().1, "\"fast\"");
    assert_eq!(
        parse_set("out=nosuchdir/x.ply", dir.path()).unwrap().1,
        "\"nosuchdir/x.ply\""
    );
    assert_eq!(parse_set("k=0.5", dir.path()).unwrap().1, "0.5");
    assert!(parse_set("novalue", dir.path()).is_err());
}

#[test]
fn set_values_of_path_params_become_absolute_before_they_exist() {
    let dir = tempdir();
    let g = write(
        dir.path(),
        "g.ron",
        r#"Graph(
  params: { "mesh": "../data/x.off", "scan": "scan.ply", "out": "../out/x", "dir": "res",
            "method": "fast", "k": "1.5", "n": 3 },
  nodes: { "r": (kind: "toy.read_file", params: (path: "${dir}/$method.txt")) },
)"#,
    );
    let graph = Graph::from_file(&g).unwrap();
    let names: Vec<String> = crestflow_flow::path_params(&graph).into_iter().collect();
    // A folder part or a file extension in the default, or a use as a folder (`${dir}/`);
    // "1.5" is a number written as a string, "fast" a word.
    assert_eq!(names, ["dir", "mesh", "out", "scan"]);
    let cwd = dir.path().join("shell");
    std::fs::create_dir(&cwd).unwrap();
    let abs = |s: &str| crestflow_flow::spanned::quote(&cwd.join(s).to_string_lossy());
    let set = |a: &str| parse_set_for(a, &cwd, &graph).unwrap().1;
    // Nothing of these exists yet: they are still taken relative to the shell's folder.
    assert_eq!(set("out=results"), abs("results"));
    assert_eq!(set("dir=new"), abs("new"));
    assert_eq!(set("mesh=nosuchdir/y.off"), abs("nosuchdir/y.off"));
    // Without the graph the same words stay strings (resolved beside the graph file).
    assert_eq!(parse_set("out=results", &cwd).unwrap().1, "\"results\"");
    // Other params keep the rules of `parse_set`.
    assert_eq!(set("method=slow"), "\"slow\"");
    assert_eq!(set("k=2"), "2");
    // Absolute paths stay as they are.
    let elsewhere = dir.path().join("elsewhere").to_string_lossy().into_owned();
    assert_eq!(
        set(&format!("out={elsewhere}")),
        crestflow_flow::spanned::quote(&elsewhere)
    );
}

#[test]
fn a_file_written_twice_or_over_an_input_is_refused() {
    let dir = tempdir();
    write(dir.path(), "in.txt", "abc");
    let reg = toy_registry();
    let errors = |text: &str| -> Vec<(String, usize)> {
        let g = write(dir.path(), "g.ron", text);
        match load_file(&g, &reg, &[]) {
            Ok(_) => Vec::new(),
            Err(e) => e
                .of(DiagKind::FileConflict)
                .iter()
                .map(|d| (d.message.clone(), d.line))
                .collect(),
        }
    };
    // Two spellings of one file: a race between the two writers.
    let twice = errors(
        r#"Graph(nodes: {
  "r": (kind: "toy.read_file", params: (path: "in.txt")),
  "a": (kind: "toy.write_text", params: (path: "out/x.txt"), inputs: { "x": "r.len" }),
  "b": (kind: "toy.write_text", params: (path: "./out/../out/x.txt"), inputs: { "x": "r.len" }),
})"#,
    );
    assert_eq!(twice.len(), 1, "{twice:?}");
    assert!(
        twice[0].0.contains("nodes `a` and `b` both write"),
        "{twice:?}"
    );
    assert_eq!(twice[0].1, 4);
    // Writing the file the graph reads.
    let over = errors(
        r#"Graph(nodes: {
  "r": (kind: "toy.read_file", params: (path: "in.txt")),
  "w": (kind: "toy.write_text", params: (path: "sub/../in.txt"), inputs: { "x": "r.len" }),
})"#,
    );
    assert_eq!(over.len(), 1, "{over:?}");
    assert!(
        over[0].0.contains("node `w` would write") && over[0].0.contains("which node `r` reads"),
        "{over:?}"
    );
    // Different files are fine.
    let fine = errors(
        r#"Graph(nodes: {
  "r": (kind: "toy.read_file", params: (path: "in.txt")),
  "a": (kind: "toy.write_text", params: (path: "out/x.txt"), inputs: { "x": "r.len" }),
  "b": (kind: "toy.write_text", params: (path: "out/y.txt"), inputs: { "x": "r.len" }),
})"#,
    );
    assert_eq!(fine, Vec::new());
}

#[test]
fn graphs_built_in_code_are_checked_too() {
    let reg = toy_registry();
    let mut g = Graph::new(".");
    g.node("c", "toy.const", "(value: 4.0)");
    g.node("s", "toy.add", "")
        .input("a", "c.value")
        .input("b", "c.vlaue");
    let e = match load(&g, &reg, &[]) {
        Err(e) => e,
        Ok(_) => panic!("should not load"),
    };
    assert_eq!(e.diagnostics.len(), 1);
    assert_eq!(e.diagnostics[0].kind, DiagKind::UnknownPort);
    assert_eq!(e.diagnostics[0].line, 0);
}

#[test]
fn truncated_or_garbled_files_give_errors_not_panics() {
    let reg = toy_registry();
    let dir = tempdir();
    let text = r##"Graph(
    params: { "v": 1.5, "name": "é$v" },
    nodes: {
        "c": (kind: "toy.const", params: (value: "$v")), // ünïcode comment
        "s": (kind: "toy.add", params: (offset: 2.0), inputs: { "a": "c.value", "b": "c.value" }),
        "r": (kind: "toy.read_file", params: (path: r#"x"y.txt"#)),
    },
)"##;
    let p = dir.path().join("g.ron");
    let mut errors = 0;
    for (cut, _) in text.char_indices() {
        std::fs::write(&p, &text[..cut]).unwrap();
        if let Err(e) = load_file(&p, &reg, &[]) {
            errors += 1;
            assert!(!e.diagnostics.is_empty());
            for d in &e.diagnostics {
                if let Some(s) = &d.span {
                    assert!(s.start <= cut, "span beyond the text at cut {cut}");
                }
            }
        }
    }
    // Every strict prefix is broken.
    assert_eq!(errors, text.char_indices().count());
    std::fs::write(&p, text).unwrap();
    assert!(load_file(&p, &reg, &[]).is_ok());
    // Nesting deeper than the reader allows is an error too.
    let deep = format!(
        "Graph(nodes: {{}}, params: {{ \"x\": {}1{} }})",
        "[".repeat(500),
        "]".repeat(500)
    );
    std::fs::write(&p, deep).unwrap();
    assert!(load_file(&p, &reg, &[]).unwrap_err().has(DiagKind::Syntax));
}

/// A graph path that is a folder, a device or a pipe is refused by name before anything is
/// read: reading `/dev/zero` or a pipe nobody writes would never end.
#[test]
fn a_graph_path_that_is_not_a_regular_file_is_refused() {
    let dir = tempdir();
    let mut paths = vec![dir.path().to_path_buf()];
    #[cfg(unix)]
    {
        let device = dir.path().join("device.ron");
        std::os::unix::fs::symlink("/dev/null", &device).unwrap();
        let fifo = dir.path().join("fifo.ron");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        paths.extend([device, fifo]);
    }
    for p in paths {
        let e = match load_file(&p, &toy_registry(), &[]) {
            Err(e) => e,
            Ok(_) => panic!("{} loaded", p.display()),
        };
        let text = e.to_string();
        assert!(
            text.contains(&*p.to_string_lossy()) && text.contains("not a regular file"),
            "{text}"
        );
        assert_eq!(kinds_lines(&e)[0].0, DiagKind::Io);
    }
}

/// A graph saved with a UTF-8 byte-order mark loads like the same text without it.
#[test]
fn a_byte_order_mark_before_the_graph_is_skipped() {
    let dir = tempdir();
    let text = r#"Graph(nodes: { "c": (kind: "toy.const", params: (value: 2.5)) })"#;
    let plain = write(dir.path(), "plain.ron", text);
    let marked = write(dir.path(), "marked.ron", &format!("\u{feff}{text}"));
    let reg = toy_registry();
    let a = load_file(&plain, &reg, &[]).unwrap();
    let b = load_file(&marked, &reg, &[]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(a.nodes.len(), 1);
    assert_eq!(b.nodes.len(), a.nodes.len());
    assert_eq!(b.nodes[0].name, "c");
}
