// The result as the page holds it: the library's (packages/gmmcalib/result.d.ts, generated from
// the Rust types) with what the page's workers add. Read by JSDoc in the `// @ts-check` modules.
import type { CalibrationResult, MethodFailure } from '../../packages/gmmcalib/index';

export type * from '../../packages/gmmcalib/result';
export type { MethodFailure };

export type PageResult = CalibrationResult & {
  /** Workers that shared the run. */
  workers?: number;
  /** Where JRMPC's E-step ran, and on which adapter when on the GPU. */
  eStepDevice?: 'gpu' | 'cpu';
  gpu?: string;
  gpuEStepSeconds?: number;
  gpuIterations?: number;
};
