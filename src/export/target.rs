//! The reconstructed target as a point file: the mixture's components that hold data.

/// The reconstructed target as a result reports it: per component its mean (flat: x, y, z,
/// ...), sigma and prior. The lengths agree (3, 1 and 1 per component).
#[derive(Clone, Copy, Debug)]
pub struct Target<'a> {
    pub means: &'a [f64],
    pub sigmas: &'a [f64],
    pub priors: &'a [f64],
}

/// ASCII PLY of the components with a positive prior, each a vertex with its sigma (m) and
/// prior, in `parent` (the frame the reference's nominal is given in). `None` for a method
/// that reconstructs nothing.
pub fn target_ply(target: Target, parent: &str) -> Option<String> {
    if target.priors.is_empty() {
        return None;
    }
    let used: Vec<usize> = (0..target.priors.len()).filter(|&k| target.priors[k] > 0.0).collect();
    let mut out = format!(
        "ply\nformat ascii 1.0\ncomment gmmcalib reconstructed target ({parent} frame, m)\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float sigma\nproperty float prior\nend_header\n",
        used.len()
    );
    for k in used {
        let m = &target.means[3 * k..3 * k + 3];
        let values = [m[0], m[1], m[2], target.sigmas[k], target.priors[k]];
        out += &values.map(as_f32).join(" ");
        out.push('\n');
    }
    Some(out)
}

/// `x` as the f32 the file declares, in the shortest text that reads back to it: the same
/// text whether the target came as f64 (a result) or as f32 (the page's copy of it).
fn as_f32(x: f64) -> String {
    format!("{}", x as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_the_components_that_hold_data() {
        let means = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 0.1 + 0.2, -7.25, 1e-3];
        let target =
            Target { means: &means, sigmas: &[0.01, 0.02, 0.03], priors: &[0.5, 0.0, 0.5] };
        let ply = target_ply(target, "base_link").unwrap();
        assert!(ply.contains("(base_link frame, m)\nelement vertex 2\n"));
        let body: Vec<&str> = ply.split("end_header\n").nth(1).unwrap().lines().collect();
        assert_eq!(body, ["1 2 3 0.01 0.5", "0.3 -7.25 0.001 0.03 0.5"]);
        let empty = Target { means: &[], sigmas: &[], priors: &[] };
        assert_eq!(target_ply(empty, "vehicle"), None);
    }
}
