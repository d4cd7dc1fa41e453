/* The narrow-band half-width that keeps bars up to a persistence threshold exact
 * (mgs_persistence.h). */
#include <math.h>
#include "topo/mgs_persistence.h"

int mgs_topo_band_for_threshold(double max_persistence, double level, double voxel_size) {
  if (!isfinite(max_persistence) || !isfinite(level) || !isfinite(voxel_size) || max_persistence < 0 ||
      voxel_size <= 0)
    return -1;
  const double w = floor((fabs(level) + max_persistence) / voxel_size) + 1;
  return w > 1e6 ? -1 : (int)w;
}
