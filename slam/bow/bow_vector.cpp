#include "slam/bow/bow_vector.hpp"

#include <cmath>

namespace coloc::slam::bow {

double score_l1(const BowVector& a, const BowVector& b) {
  // With both vectors normalised, |a - b|_1 = 2 + sum over common words of
  // (|a_i - b_i| - |a_i| - |b_i|), so only common words need visiting. Writing the last two as
  // one sum (|a_i| + |b_i| is commutative in IEEE arithmetic) keeps the score exactly symmetric.
  double sum = 0.0;
  auto ia = a.entries.begin();
  auto ib = b.entries.begin();
  while (ia != a.entries.end() && ib != b.entries.end()) {
    if (ia->word < ib->word) {
      ++ia;
    } else if (ib->word < ia->word) {
      ++ib;
    } else {
      sum += std::abs(ia->weight - ib->weight) - (std::abs(ia->weight) + std::abs(ib->weight));
      ++ia;
      ++ib;
    }
  }
  return -0.5 * sum;
}

}  // namespace coloc::slam::bow
