// Internal: a cloud's rows taken along a Morton curve (util/spatial_order.hpp) for a whole stage
// and its result handed back in input rows. NH-Net's stage reads each point's neighbourhood
// through tables in input rows (descriptors' gathers, the candidate mix, the learned fit); on a
// shuffled cloud those reads scatter over the whole cloud. Run on the rows in this order, they
// read nearby memory; the stage's results do not depend on the input order (the estimator's
// canonical order, neighbors/dedupe.hpp), so only the time changes.
#pragma once

#include "nhnet/pipeline/estimate.hpp"
#include "pipeline/estimator.hpp"

#include <cstdint>
#include <vector>

namespace nhnet::detail {

/// The rows of `points` along the curve: row i of the permuted cloud is input row order[i].
struct RowOrder {
  std::vector<int64_t> order;
};

/// The order of `points`' rows along the curve (non-finite rows last).
RowOrder row_order(const Points& points);

/// `points` with its rows in `o`'s order.
Points permute_rows(const Points& points, const RowOrder& o);

/// A result computed on permute_rows(points, o) back in input rows: every per-point output and
/// every row index it holds (neighbour table, MFPS blend rows).
void restore_rows(EstimateResult& res, const RowOrder& o);

/// `prepared` (built on the input rows) made what it would have been built on `permuted`
/// (= permute_rows(points, o)): the canonical points, tree and probe do not depend on the row
/// order (neighbors/dedupe.hpp); the canonical rows and copies are renumbered, every exact
/// copy's first being its lowest permuted row, as canonical_points gives.
void permute_prepared(Prepared& prepared, const RowOrder& o, const Points& permuted);

}  // namespace nhnet::detail
