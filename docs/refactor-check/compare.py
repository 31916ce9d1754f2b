# Compare the decoded channels of two folders of EXRs (the writer orders chunks by thread).
import OpenEXR, numpy as np, sys, glob, os
a, b = sys.argv[1], sys.argv[2]
bad = 0; n = 0
for f in sorted(glob.glob(a + '/*.exr')):
    g = os.path.join(b, os.path.basename(f)); n += 1
    if not os.path.exists(g): print('MISSING', g); bad += 1; continue
    A = OpenEXR.File(f).channels(); B = OpenEXR.File(g).channels()
    if set(A) != set(B): print('CHANNELS', f); bad += 1; continue
    d = [k for k in A if not np.array_equal(A[k].pixels, B[k].pixels, equal_nan=True)]
    if d:
        bad += 1
        k = d[0]; x = A[k].pixels.astype(np.float64); y = B[k].pixels.astype(np.float64)
        print('DIFF', os.path.basename(f), d[:4], 'max abs', np.nanmax(np.abs(x - y)), 'mean', np.nanmean(x), np.nanmean(y))
print(f'{bad} of {n} differ')
