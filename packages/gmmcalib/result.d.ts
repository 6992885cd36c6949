// Generated from the Rust types by tests/report.rs (ts-rs): do not edit. The result of
// `calibrate` (the CLI's --json), its exports and the drift check. Units: m and rad; `T_a_b` maps
// points from frame b into frame a.

/** 16 numbers, a row-major 4x4 rigid transform. */
export type Matrix4 = number[];

export type MethodName = 'gmm' | 'jrmpc' | 'cad' | 'p2p' | 'p2l' | 'gicp';

export type Report = { 
/**
 * How far to trust the result, and why: read it first.
 */
verdict: VerdictReport, method: MethodName, reference: string, iterations: number, converged: boolean, cancelled: boolean, 
/**
 * JRMPC ran with its exact E-step (`--exact`).
 */
exact: boolean, sensors: Array<SensorReport>, reconstruction: ReconstructionReport, 
/**
 * Views left out.
 */
skipped: Array<NoteReport>, 
/**
 * Per non-reference sensor, every stage's hypothesis, scored on the whole scans, and the
 * one chosen (docs/method.md, "Selection").
 */
selection: Array<SelectionReport>, 
/**
 * `gmm`'s plane adjustment per non-reference sensor (frame `all`): the motion applied, or
 * why the refinement was kept; empty when it is off.
 */
planeAdjustment: Array<NoteReport>, 
/**
 * Per sensor, the ground found and the levelling applied before cropping (`gmm`; empty
 * when levelling is off).
 */
levelling: Array<LevellingReport>, 
/**
 * Per sensor, the global alignment from the nominal (`gmm`; empty when off).
 */
global: Array<GlobalReport>, 
/**
 * The region cropped to (m, vehicle frame): the given one, else around the targets found,
 * else where the clouds overlap.
 */
roi: RoiReport, history: HistoryReport, };

export type Level = "good" | "check" | "failed";

export type VerdictReport = { level: Level, 
/**
 * Calibration-wide reasons.
 */
reasons: Array<ReasonReport>, sensors: { [key in string]: SensorVerdictReport }, };

export type SensorVerdictReport = { level: Level, reasons: Array<ReasonReport>, 
/**
 * The measurements (none for the reference sensor).
 */
evidence: SensorEvidence | null, };

export type ReasonReport = { kind: string, level: Level, text: string, values: { [key in string]: Value }, };

export type Value = number | string | Array<string>;

export type SensorEvidence = { 
/**
 * Under the nominal (levelling and search undone) and under the calibration.
 */
before: Agreement, after: Agreement, 
/**
 * All frames together, under the calibration.
 */
observability: Observability, 
/**
 * One frame's, on average: what a frame's correction can be trusted to.
 */
frameObservability: Observability, 
/**
 * The residual noise measured on the agreeing points (m).
 */
noise: number, };

export type Agreement = { 
/**
 * Sensor points compared (sampled).
 */
points: number, 
/**
 * Of those, the points with a reference surface within `radius`.
 */
overlapping: number, 
/**
 * Of those, the points within `tolerance` of that surface.
 */
agreeing: number, 
/**
 * The same three counts for the points standing above the reference's ground (all
 * points when no ground is known): the structure that fixes yaw and the shift.
 */
structure: [number, number, number], 
/**
 * How near a reference point must be for a surface to count as overlapping (m).
 */
radius: number, 
/**
 * Distance to the surface within which a point agrees (m): three noise widths.
 */
tolerance: number, };

export type Observability = { 
/**
 * Rotation about the vehicle's x, y, z axes (rad).
 */
rotation: [number, number, number], 
/**
 * Translation along x, y, z (m).
 */
translation: [number, number, number], };

export type SensorReport = { name: string, 
/**
 * `C_ref_s`, row-major.
 */
correction: Matrix4, 
/**
 * Corrected `T_vehicle_sensor`, row-major.
 */
extrinsic: Matrix4, 
/**
 * `T_ref_s`, row-major.
 */
relative: Matrix4, 
/**
 * Translation (m) of the corrected extrinsic.
 */
xyz: [number, number, number], 
/**
 * Roll, pitch, yaw (rad) of the corrected extrinsic.
 */
rpy: [number, number, number], 
/**
 * Per-axis spread of the per-frame corrections (m, rad) over `frames` frames.
 */
spread: Spread, 
/**
 * One sigma: rotation about the vehicle's x, y, z axes (rad), and the sensor's position
 * (m); null where no plane adjustment or selection measured it.
 */
precision: Precision | null, };

export type Spread = { 
/**
 * Translation, m.
 */
xyz: [number, number, number], 
/**
 * Rotation about x, y, z (rad), from the rotation vector of `mean^-1 C(f)`.
 */
rpy: [number, number, number], 
/**
 * Frames averaged.
 */
frames: number, };

export type Precision = { 
/**
 * Rotation about the vehicle's x, y, z axes (rad).
 */
rotation: [number, number, number], 
/**
 * The sensor's position along x, y, z (m).
 */
position: [number, number, number], };

export type ReconstructionReport = { 
/**
 * Component means, flat: x, y, z, x, y, z, ... (m).
 */
means: Array<number>, 
/**
 * Component standard deviations (m).
 */
sigmas: Array<number>, priors: Array<number>, 
/**
 * The target's shape fitted to each target off the ground, largest first.
 */
fits: Array<ShapeFit>, 
/**
 * Where a CAD-model target was found in the reference's data before registration, best
 * first (empty for the other targets).
 */
placements: Array<PlacementReport>, };

export type ShapeFit = { 
/**
 * The shape fitted: `cube` or `sphere` ([`Target::kind`]).
 */
shape: string, 
/**
 * RMS distance (m) of the means from the fitted surface, weighted by the mixture's priors.
 */
rms: number, 
/**
 * Fitted size (m): cube edge, a box's largest edge or sphere diameter.
 */
size: number, 
/**
 * Fitted extents (m) along the shape's own axes: a box's three edges, else `size` thrice.
 */
extents: [number, number, number], 
/**
 * Fitted centre (m).
 */
centre: [number, number, number], 
/**
 * Fitted orientation: rotation vector (rad) from the shape's axes to the means' frame.
 */
rotation: [number, number, number], 
/**
 * Share of the fitted components' weight within 10% of the size from the surface.
 */
inlierShare: number, 
/**
 * Share of the mixture's weight off the ground that this fit covers.
 */
weight: number, };

export type PlacementReport = { 
/**
 * `T_vehicle_model`, row-major 4x4, and as xyz (m) and roll, pitch, yaw (rad).
 */
pose: Matrix4, xyz: [number, number, number], rpy: [number, number, number], 
/**
 * The reference's points fitted, the share within the tolerance, their RMS distance (m).
 */
points: number, inliers: number, rms: number, };

export type NoteReport = { sensor: string, 
/**
 * The frame, or `all` for a note on every frame of the sensor.
 */
frame: string, 
/**
 * The note's kind (`tooFewPoints`, `frameOutlier`, `planesApplied`, ...).
 */
kind: string, 
/**
 * The note in words.
 */
reason: string, };

export type SelectionReport = { sensor: string, 
/**
 * Index of the chosen hypothesis.
 */
chosen: number, hypotheses: Array<HypothesisReport>, };

export type HypothesisReport = { 
/**
 * `nominal`, `global`, `levelled`, `jrmpc`, `cad`, `refinedFromNominal`,
 * `refinedFromStart`, `refined`, `refinedOnScene` or `planes`.
 */
stage: string, 
/**
 * A global candidate's rank (0: the global stage's best overlay).
 */
rank: number | null, 
/**
 * The hypothesis it was refined from.
 */
parent: number | null, correction: Matrix4, 
/**
 * The selection's score: `landing` less three times `contradiction`
 * (`select::CONTRADICTION_WEIGHT`; -3..1).
 */
score: number, 
/**
 * Share of the points compared that land on another sensor's surfaces (0..1).
 */
landing: number, 
/**
 * Share of the points compared that stand where another sensor saw through (0..1).
 */
contradiction: number, 
/**
 * Share of the points compared with another sensor's surface beside them (0..1).
 */
overlap: number, 
/**
 * How its ground meets the other sensors' where they see the same patches; absent
 * without a reference ground or shared patches.
 */
ground: GroundReport | null, };

export type GroundReport = { patches: number, height: number, tilt: number, heightSigma: number, tiltSigma: number, };

export type LevellingReport = { sensor: string, 
/**
 * The ground plane `[nx, ny, nz, d]` (`n . p + d = 0`, m) in the nominal vehicle frame;
 * null when none was found.
 */
ground: [number, number, number, number] | null, 
/**
 * Ground points found (all frames).
 */
inliers: number, 
/**
 * The motion applied to the pre-aligned points (levelling, then the bird's-eye search),
 * row-major.
 */
motion: Matrix4, 
/**
 * Why no levelling was applied, if none was.
 */
note: string | null, 
/**
 * The bird's-eye search's yaw and shift, included in `motion`.
 */
bev: BevAlignment | null, 
/**
 * What to check, if anything: a bird's-eye search that found nothing to overlay, little
 * overlap, or its best at the edge of its range.
 */
warning: string | null, 
/**
 * `nothingToOverlay`, `lowOverlap` or `atEdge`, with `warning`.
 */
warningKind: string | null, };

export type BevAlignment = { 
/**
 * Yaw about the ground normal through the sensor (rad).
 */
yaw: number, 
/**
 * Shift of the sensor along the ground (m, vehicle frame).
 */
shift: [number, number, number], 
/**
 * The sensor's structure points on the reference's, weighted by closeness, at the best
 * candidate and with no change.
 */
score: number, scoreUnchanged: number, 
/**
 * The best candidate lies on the border of the range searched (the largest yaw or shift):
 * the sensor may be off by more than the search covers, and the true overlay lie beyond.
 */
atEdge: boolean, };

export type GlobalReport = { sensor: string, 
/**
 * The motion applied on top of the nominal, row-major.
 */
motion: Matrix4, 
/**
 * The ground found in the sensor's frame: its angle from the nominal's up (rad) and the
 * sensor's height above it (m).
 */
groundTilt: number | null, groundHeight: number | null, groundsTried: number, 
/**
 * The overlay from above: the best placement, the distinct runners-up, and the best
 * runner-up's score over the best's.
 */
overlay: OverlayReport | null, 
/**
 * Why it was not applied, if it was not.
 */
skipped: string | null, };

export type OverlayReport = { best: CandidateReport, runnersUp: Array<CandidateReport>, ambiguity: number, };

export type CandidateReport = { yaw: number, shift: [number, number, number], score: number, };

export type RoiReport = { min: [number, number, number], max: [number, number, number], } & ({ "source": "given" } | { "source": "targets", found: number, } | { "source": "overlap" });

export type RoiSource = { "source": "given" } | { "source": "targets", found: number, } | { "source": "overlap" };

export type HistoryReport = { meanSigma: Array<number>, maxChange: Array<number>, 
/**
 * Gaussian terms the E-step evaluated.
 */
terms: Array<number>, };

export type DriftReport = { passed: boolean, reference: string, sensors: Array<SensorDriftReport>, missing: Array<string>, added: Array<string>, 
/**
 * One sentence per sensor that moved, changed within the calibrations' scatter, or went
 * missing.
 */
findings: Array<string>, };

export type SensorDriftReport = { name: string, moved: boolean, 
/**
 * Beyond the fixed limit, within three combined sigmas of both calibrations' precision:
 * not a move the two can tell from their own scatter.
 */
unresolved: boolean, 
/**
 * Rotation vector of the change (rad) and its angle.
 */
rotation: [number, number, number], angle: number, 
/**
 * Position change (m) and its length.
 */
translation: [number, number, number], distance: number, 
/**
 * The new calibration's one sigma.
 */
precision: Precision | null, limit: LimitReport, };

export type LimitReport = { "kind": "fixed", rotation: number, translation: number, } | { "kind": "sigmas", sigmas: number, rotation: [number, number, number], position: [number, number, number], };

export type Exports = { parent: string, 
/**
 * The result as `gmmcalib calibrate --json` writes it (absent when made from the
 * extrinsics alone: it names no frame, so a renamed parent leaves it as it was).
 */
json?: string, 
/**
 * GMMCalib's `config.yaml` with the calibrated transforms and the ROI.
 */
gmmcalibYaml: string, urdf: string, ros1: string, ros2: string, tfYaml: string, autoware: string, kitti: string, 
/**
 * The reconstructed target as PLY (absent for a method that reconstructs nothing).
 */
targetPly?: string, };
