// Hand-written types for the gmmcalib package: the shapes of docs/api.md. wasm-bindgen's own
// declarations type inputs and results as `any`; these say what crosses. Units: m and rad;
// matrices are 16 numbers, row-major; `T_a_b` maps points from frame b into frame a.

/** 16 numbers, a row-major 4x4 rigid transform. */
export type Matrix4 = number[];
export type Vec3 = [number, number, number];

/** A pose as translation (m) and roll, pitch, yaw about the fixed x, y, z axes (rad). */
export interface XyzRpy {
  xyz: Vec3;
  rpy: Vec3;
}

export type MethodName = 'gmm' | 'jrmpc' | 'cad' | 'p2p' | 'p2l' | 'gicp';

export type Target =
  | { kind: 'cube'; edge: number }
  | { kind: 'box'; size: Vec3 }
  | { kind: 'sphere'; diameter: number }
  | { kind: 'mesh' }
  | { kind: 'none' };

/** One scan: `points` is x, y, z, x, y, z, ... in the sensor frame (m). */
export interface Scan {
  sensor: string;
  frame: string;
  points: Float32Array;
}

/**
 * What a user sets, under the keys every door shares: config.yaml (snake_case there), the CLI's
 * flags and this input. Unset keeps the library's default (`defaults()`).
 */
export interface SettingsInput {
  /** A method, several joined by commas (compared), or 'all'. Default 'gmm'. */
  method?: MethodName | 'all' | string;
  /** `cube:EDGE`, `box:W,D,H`, `sphere:DIAMETER`, `mesh:NAME` (its file in `targetMesh`) or `none`, or the object form. Default a 0.5 m cube. */
  target?: string | Target;
  components?: number;
  /** The most EM iterations (JRMPC's or cad's). */
  iterations?: number;
  /** EM's convergence test, for whichever method runs; default each method's own. */
  tolerance?: number;
  multiresolution?: boolean;
  /** JRMPC's exact E-step: every point against every component in f64 (7-13x slower). */
  exact?: boolean;
  initialSigma?: 'bbox' | 'prior' | number;
  seed?: number;
  /** The global alignment first; default: for the methods that run it (`gmm`, `cad`). Also read as `alignGlobally`. */
  global?: boolean;
  /** Levelling onto the reference's ground; default: for `gmm` and `cad`. */
  level?: boolean;
  /** The search from above after levelling. Default true. */
  bev?: boolean;
  /** Refine only, from the nominal. */
  refine?: boolean;
  threads?: number;
}

export interface CalibrationInput extends SettingsInput {
  scans: Scan[];
  /** Nominal `T_vehicle_sensor` per sensor. */
  nominal: Record<string, XyzRpy>;
  /** Vehicle frame, m, inclusive; default: where the sensors' clouds overlap. */
  roi?: { min: Vec3; max: Vec3 };
  /** Default: the sensor with the most points. */
  reference?: string;
  targetMesh?: { name: string; bytes: Uint8Array };
  /** The former name of `global`. */
  alignGlobally?: boolean;
}

/** The library's defaults, as a user would write them (the EM tolerance differs by method and is left out). */
export function defaults(): SettingsInput;

export type Stage = 'global' | 'views' | 'jrmpc' | 'cad' | 'framePairs' | 'finish';

export interface Progress {
  method: MethodName;
  /** 'global': the sensors aligned globally so far, of `maxIterations`; 'views' and 'finish':
   * one step each (the views prepared; the result made), said as it begins (0 of 1). */
  stage: Stage;
  /** The stages the method goes through, in order: what a progress bar shares out. */
  stages: Stage[];
  iteration: number;
  maxIterations: number;
  /** m; 0 for frame pairs. */
  meanSigma: number;
  /** rad or m; 0 for frame pairs. */
  maxChange: number;
  /** The current `C_ref_s` per sensor, in result order. */
  corrections: Matrix4[];
  sensors: string[];
}

/** Return `false` to stop the stage under way. */
export type OnProgress = (p: Progress) => boolean | void;

/** One sigma: rotation about the vehicle's x, y, z axes (rad) and position (m). */
export interface Precision {
  rotation: Vec3;
  position: Vec3;
}

export type Level = 'good' | 'check' | 'failed';

export interface Reason {
  kind: string;
  level: Level;
  text: string;
  values: Record<string, number | string | string[]>;
}

export interface Verdict {
  level: Level;
  reasons: Reason[];
  sensors: Record<string, { level: Level; reasons: Reason[]; evidence: Record<string, unknown> | null }>;
}

export interface SensorResult {
  name: string;
  /** `C_ref_s`. */
  correction: Matrix4;
  /** Corrected `T_vehicle_sensor`. */
  extrinsic: Matrix4;
  /** `T_ref_s`. */
  relative: Matrix4;
  xyz: Vec3;
  rpy: Vec3;
  spread: { xyz: Vec3; rpy: Vec3; frames: number };
  /** `gmm`, for every sensor the plane adjustment moved; null otherwise. */
  precision: Precision | null;
}

export interface Note {
  sensor: string;
  /** A frame, or 'all'. */
  frame: string;
  kind: string;
  reason: string;
}

export interface ShapeFit {
  shape: 'cube' | 'box' | 'sphere' | 'mesh';
  rms: number;
  size: number;
  extents: Vec3;
  centre: Vec3;
  rotation: Vec3;
  /** Share of the fitted components' weight within 10 % of the size from the surface. */
  inlierShare: number;
  weight: number;
}

export interface Placement {
  pose: Matrix4;
  xyz: Vec3;
  rpy: Vec3;
  points: number;
  inliers: number;
  rms: number;
}

export interface Levelling {
  sensor: string;
  ground: [number, number, number, number] | null;
  inliers: number;
  motion: Matrix4;
  note: string | null;
  bev: { yaw: number; shift: Vec3; score: number; scoreUnchanged: number; atEdge: boolean } | null;
  warning: string | null;
  warningKind: 'nothingToOverlay' | 'lowOverlap' | 'atEdge' | null;
}

/** `calibrate`'s result (and, with numbers instead of Float32Arrays, the CLI's --json). */
export interface CalibrationResult {
  verdict: Verdict;
  method: MethodName;
  reference: string;
  iterations: number;
  converged: boolean;
  cancelled: boolean;
  /** JRMPC ran with its exact E-step (`exact: true`). */
  exact: boolean;
  sensors: SensorResult[];
  reconstruction: {
    means: Float32Array;
    sigmas: Float32Array;
    priors: Float32Array;
    fits: ShapeFit[];
    placements: Placement[];
  };
  skipped: Note[];
  /** Per non-reference sensor, every stage's hypothesis scored on the whole scans, and the one chosen. */
  selection: SensorSelection[];
  planeAdjustment: Note[];
  levelling: Levelling[];
  global: Record<string, unknown>[];
  /** The region cropped to: the given ROI, around the `found` objects of the target's shape
   * standing in the reference's scans, or the clouds' overlap. */
  roi: { min: Vec3; max: Vec3 } & ({ source: 'given' | 'overlap' } | { source: 'targets'; found: number });
  history: { meanSigma: number[]; maxChange: number[]; terms: number[] };
}

/** One sensor's hypotheses and the one chosen (docs/method.md, "Selection"). */
export interface SensorSelection {
  sensor: string;
  /** Index of the chosen hypothesis. */
  chosen: number;
  hypotheses: Hypothesis[];
}

/** One placement a stage proposed. */
export interface Hypothesis {
  stage:
    | 'nominal'
    | 'global'
    | 'levelled'
    | 'jrmpc'
    | 'cad'
    | 'refinedFromNominal'
    | 'refinedFromStart'
    | 'refined'
    | 'planes';
  /** A global candidate's rank (0: the global stage's best overlay). */
  rank: number | null;
  /** The hypothesis it was refined from. */
  parent: number | null;
  /** On top of the nominal, row-major 4x4. */
  correction: number[];
  /** The selection's score: `landing` less `contradiction` (-1..1). */
  score: number;
  /** Share of the points landing on another sensor's surfaces (0..1). */
  landing: number;
  /** Share of the points standing where another sensor saw through (0..1). */
  contradiction: number;
  /** Share of the points with another sensor's surface beside them (0..1). */
  overlap: number;
}

/** With `method: 'all'`: a method that failed. */
export interface MethodFailure {
  method: MethodName;
  error: string;
}

export function calibrate(input: CalibrationInput & { method?: MethodName }, onProgress?: OnProgress): CalibrationResult;
export function calibrate(
  input: CalibrationInput & { method: 'all' },
  onProgress?: OnProgress,
): (CalibrationResult | MethodFailure)[];

export interface MethodInfo {
  name: MethodName;
  label: string;
  jrmpc: boolean;
  pairs: boolean;
}
export function methods(): MethodInfo[];

/** A GMMCalib config: the nominals, the ROI, the reference and the settings it sets (a cube's `target_edge` as its `target`). */
export interface Config extends SettingsInput {
  nominal: Record<string, XyzRpy>;
  roi: { min: Vec3; max: Vec3 } | null;
  reference: string | null;
  target?: string;
}
export function parseConfig(text: string, fileName: string): Config;

export interface ParsedCloud {
  points: Float32Array;
  intensity?: Float32Array;
  count: number;
  dropped: number;
  format: string;
  width: number;
  height: number;
  viewpointApplied: boolean;
}
export function parseCloud(bytes: Uint8Array, fileName: string): ParsedCloud;

/** Which scan file is which sensor and frame, from '/'-separated paths alone (as the CLI and
 * the page read a folder): GMMCalib's `sensor_N/`, a folder per sensor under any name, loose
 * `<sensor>_<frame>` or `<frame>_<sensor>` files; frames paired by the nearest timestamp where
 * names do not pair them. */
export interface Layout {
  scans: { path: string; sensor: string; frame: string }[];
  /** How frames were paired, in words. */
  pairings: string[];
  /** Loose files whose names carry no sensor, each placed as a sensor of its own name. */
  nameless: string[];
  /** The frame shared by loose `<frame>_<sensor>` files, when read that way. */
  sensorsLast: string | null;
  /** Files that would be one sensor's one frame after `first`: left out of `scans`. */
  duplicates: { first: string; second: string; frame: string }[];
}
export function placeScans(paths: string[]): Layout;

export interface SimulateOptions {
  preset?: 'paper' | 'paper-roof' | 'os1-128' | 'sampled' | 'paper-chair' | 'paper-board' | 'street';
  frames?: number;
  seed?: number;
  maxAngleDeg?: number;
  maxTranslation?: number;
  sensors?: number;
  pointsPerView?: number;
  noise?: number;
  partial?: boolean;
}
export interface SimulatedRig {
  scans: (Scan & { dropped: number })[];
  nominal: Record<string, XyzRpy>;
  truth: Record<string, XyzRpy>;
  roi: { min: Vec3; max: Vec3 };
  reference: string;
  target: string;
  targetObj: string | null;
}
export function simulateRig(options?: SimulateOptions): SimulatedRig;

/** The drift check's limits; defaults 0.1 deg and 0.01 m. With `sigmas`, K times the
 *  combined one-sigma precision per axis (sensors without a precision keep the fixed ones). */
export interface ToleranceOptions {
  rotationDeg?: number;
  translation?: number;
  sigmas?: number;
}

export type Limit =
  | { kind: 'fixed'; rotation: number; translation: number }
  | { kind: 'sigmas'; sigmas: number; rotation: Vec3; position: Vec3 };

export interface SensorDrift {
  name: string;
  moved: boolean;
  /** Beyond a fixed limit, yet within 3 sigma of both calibrations' combined precision: not a move they can tell from their own scatter. */
  unresolved: boolean;
  /** Rotation vector of the change about the vehicle's axes (rad), and its angle. */
  rotation: Vec3;
  angle: number;
  /** Position change (m), and its length. */
  translation: Vec3;
  distance: number;
  /** The new calibration's one sigma. */
  precision: Precision | null;
  limit: Limit;
}

export interface DriftReport {
  passed: boolean;
  reference: string;
  sensors: SensorDrift[];
  missing: string[];
  added: string[];
  /** One sentence per sensor that moved or went missing. */
  findings: string[];
}

/** The drift check over two calibrations' texts: our JSON (calibrate --json, the page's
 *  export), a URDF or a /tf_static YAML; `current` needs our JSON for its precision. */
export function compareCalibrations(
  stored: string,
  storedName: string,
  current: string,
  currentName: string,
  tolerance?: ToleranceOptions,
): DriftReport;

/** What `runCommand` reads and writes through. Throw an Error whose message is the reason. */
export interface CommandHost {
  read(path: string): Uint8Array;
  list(dir: string): string[];
  kind(path: string): 'file' | 'dir' | 'other';
  write(path: string, bytes: Uint8Array): void;
  open(path: string): { size: number; readAt(offset: number, length: number): Uint8Array };
  out(text: string): void;
  err(text: string): void;
  progress(line: string): void;
}

/** `gmmcalib calibrate|compare ...` (argv without the program's name); the exit status. */
export function runCommand(argv: string[], host: CommandHost): number;

export function rosExports(extrinsics: { parent: string; child: string; pose: Matrix4 }[]): {
  ros1: string;
  ros2: string;
  tfYaml: string;
  urdf: string;
  autoware: string;
  kitti: string;
};

/** Browsers: resolves once the wasm is instantiated (the browser entry awaits it on import). */
export default function init(input?: unknown): Promise<unknown>;
/** Instantiates from bytes (the Node entry does this on import). */
export function initSync(module: { module: BufferSource | WebAssembly.Module }): unknown;
