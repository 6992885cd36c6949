//! The npm package's TypeScript types of what the library returns (the calibration's JSON, the
//! drift check's), generated from the Rust types that serialize it: `packages/gmmcalib/result.d.ts`
//! must be what these types declare. After changing a result type, write it again with
//! `GMMCALIB_WRITE_TYPES=1 cargo test --features ts --test report`.
#![cfg(feature = "ts")]

use gmmcalib::calib::verdict::Level;
use gmmcalib::calib::{
    Agreement, BevAlignment, Method, Observability, Precision, SensorEvidence, Spread, region,
};
use gmmcalib::export::Exports;
use gmmcalib::report::*;
use gmmcalib::targets::ShapeFit;
use ts_rs::{Config, TS};

const FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/packages/gmmcalib/result.d.ts");

fn declarations() -> String {
    // JSON numbers, whatever their width in Rust; 16-number matrices as arrays, not tuples.
    let cfg = Config::new().with_large_int("number").with_array_tuple_limit(4);
    let mut out = String::from(
        "// Generated from the Rust types by tests/report.rs (ts-rs): do not edit. The result of\n\
         // `calibrate` (the CLI's --json), its exports and the drift check. Units: m and rad; `T_a_b` maps\n\
         // points from frame b into frame a.\n\n\
         /** 16 numbers, a row-major 4x4 rigid transform. */\nexport type Matrix4 = number[];\n",
    );
    // The methods by their names in the JSON, from the library's list of them.
    let names: Vec<String> = Method::ALL.iter().map(|m| format!("'{}'", m.name())).collect();
    out += &format!("\nexport type MethodName = {};\n", names.join(" | "));
    macro_rules! declare {
        ($($t:ty),* $(,)?) => {$(
            out.push('\n');
            out.push_str("export ");
            out.push_str(&<$t>::decl(&cfg));
            out.push('\n');
        )*};
    }
    declare!(
        Report,
        Level,
        VerdictReport,
        SensorVerdictReport,
        ReasonReport,
        Value,
        SensorEvidence,
        Agreement,
        Observability,
        SensorReport,
        Spread,
        Precision,
        ReconstructionReport,
        ShapeFit,
        PlacementReport,
        NoteReport,
        SelectionReport,
        HypothesisReport,
        GroundReport,
        LevellingReport,
        BevAlignment,
        GlobalReport,
        OverlayReport,
        CandidateReport,
        RoiReport,
        region::RoiSource,
        HistoryReport,
        DriftReport,
        SensorDriftReport,
        LimitReport,
        Exports,
    );
    out
}

#[test]
fn the_packages_result_types_are_the_rust_types() {
    let text = declarations();
    if std::env::var_os("GMMCALIB_WRITE_TYPES").is_some() {
        std::fs::write(FILE, &text).expect(FILE);
    }
    let written = std::fs::read_to_string(FILE).unwrap_or_default();
    assert!(
        written == text,
        "{FILE} is not what the Rust types declare; write it again with \
         GMMCALIB_WRITE_TYPES=1 cargo test --features ts --test report"
    );
}

/// The field names in `text`'s declarations (`name: type` and `name?: type`), comments left out.
fn fields(text: &str) -> Vec<String> {
    let mut code = String::new();
    let mut rest = text;
    while let Some(start) = rest.find("/*") {
        code.push_str(&rest[..start]);
        rest = rest[start..].find("*/").map_or("", |end| &rest[start + end + 2..]);
    }
    code.push_str(rest);
    // A tag is quoted: `"source": "given"`.
    let code: String = code.lines().map(|l| l.split("//").next().unwrap_or("")).collect();
    let code = code.replace("\":", ":");
    let words =
        code.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '?' || c == ':'));
    words
        .filter_map(|w| w.strip_suffix(':'))
        .map(|w| w.trim_end_matches('?').to_string())
        .filter(|w| !w.is_empty())
        .collect()
}

/// docs/api.md's "The result" names only fields the types have, and its summary names every
/// field of `Report`: the page is checked against the types, as the package's file is.
#[test]
fn the_api_pages_result_fields_are_the_types_fields() {
    let text = declarations();
    let declared = fields(&text);
    let page =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/api.md")).unwrap();
    let section = page.split("\n## The result\n").nth(1).expect("a section 'The result'");
    let section = section.split("\n## ").next().unwrap();
    let summary = section.split("```ts\n").nth(1).and_then(|s| s.split("```").next()).unwrap();
    let identifier = |w: &&str| w.starts_with(|c: char| c.is_ascii_lowercase());
    let mut named: Vec<String> = summary
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .flat_map(|l| l.split(|c: char| !c.is_ascii_alphanumeric()).filter(identifier))
        .map(str::to_string)
        .collect();
    // Each bullet's lead, the names it opens with: "- `iterations`, `converged`: ..."; a path
    // (`history.terms`) by its last name.
    for line in section.lines().filter(|l| l.starts_with("- `")) {
        let mut rest = &line[2..];
        while let Some(name) = rest.strip_prefix('`').and_then(|r| r.split('`').next()) {
            named.push(name.rsplit('.').next().unwrap_or(name).to_string());
            rest = &rest[name.len() + 2..];
            let Some(next) = rest.strip_prefix(", ") else { break };
            rest = next;
        }
    }
    let unknown: Vec<&String> = named.iter().filter(|n| !declared.contains(n)).collect();
    assert!(unknown.is_empty(), "docs/api.md names fields the result has not: {unknown:?}");
    let report = text.split("export type Report = ").nth(1).unwrap().split("};").next().unwrap();
    let missing: Vec<String> = fields(report).into_iter().filter(|f| !named.contains(f)).collect();
    assert!(missing.is_empty(), "docs/api.md's summary leaves out {missing:?}");
}
