// The gmmcalib package's types. What the library returns (the calibration's result, the drift
// check's report) is generated from the Rust types that serialize it: ./result.d.ts (ts-rs,
// checked by tests/report.rs). The inputs and the functions are written here, in the shapes
// of docs/api.md. wasm-bindgen's own declarations type both as `any`. Units: m and rad; matrices
// are 16 numbers, row-major; `T_a_b` maps points from frame b into frame a.

import type { DriftReport, Exports, LimitReport, Matrix4, MethodName, Report, ReconstructionReport } from './result.js';

export type * from './result.js';

export type Vec3 = [number, number, number];

/** A pose as translation (m) and roll, pitch, yaw about the fixed x, y, z axes (rad). */
export interface XyzRpy {
  xyz: Vec3;
  rpy: Vec3;
}

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
  /** The vehicle frame's name: the parent of every extrinsic in the result's exports. Default `vehicle`. */
  parent?: string;
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

/** `calibrate`'s result: the CLI's --json (`Report`), with the reconstruction's bulk arrays as
 *  Float32Arrays. */
export type CalibrationResult = Omit<Report, 'reconstruction'> & {
  reconstruction: Omit<ReconstructionReport, 'means' | 'sigmas' | 'priors'> & {
    means: Float32Array;
    sigmas: Float32Array;
    priors: Float32Array;
  };
  /** The result in every form it is taken away in (`json` is the CLI's --json), the input's `parent` the vehicle frame. */
  exports: Exports;
};

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

/** The former names of the drift check's types. */
export type Limit = LimitReport;
export type SensorDrift = DriftReport['sensors'][number];

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

/** A result's exports made again for another vehicle frame (`parent`): all but `json`, which names no frame. */
export function exportsOf(input: {
  parent: string;
  sensors: { name: string; extrinsic: Matrix4 | Float64Array }[];
  roi: { min: Vec3; max: Vec3 };
  reconstruction?: { means: ArrayLike<number>; sigmas: ArrayLike<number>; priors: ArrayLike<number> };
}): Exports;

/** Browsers: resolves once the wasm is instantiated (the browser entry awaits it on import). */
export default function init(input?: unknown): Promise<unknown>;
/** Instantiates from bytes (the Node entry does this on import). */
export function initSync(module: { module: BufferSource | WebAssembly.Module }): unknown;
