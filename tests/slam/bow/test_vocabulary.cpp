#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numeric>

#include "slam/bow/vocabulary.hpp"
#include "slam/core/error.hpp"
#include "tests/slam/bow/synthetic.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::bow {
namespace {

namespace fs = std::filesystem;

const VocabularyOptions kSmall{.branching = 4, .depth = 3, .max_iterations = 10, .seed = 7};

std::vector<std::uint8_t> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

// The error load() throws for a file, or an empty optional when it loads.
std::optional<Error> load_error(const fs::path& path) {
  try {
    Vocabulary::load(path);
  } catch (const Error& e) {
    return e;
  }
  return std::nullopt;
}

TEST(VocabularyOptions, CheckNamesTheBadField) {
  EXPECT_NO_THROW(VocabularyOptions{}.check());
  auto field_of = [](VocabularyOptions o) {
    try {
      o.check();
    } catch (const Error& e) {
      return e.context().field;
    }
    return std::string("(none)");
  };
  EXPECT_EQ(field_of({.branching = 1}), "branching");
  EXPECT_EQ(field_of({.depth = 0}), "depth");
  EXPECT_EQ(field_of({.max_iterations = 0}), "max_iterations");
  EXPECT_THROW(Vocabulary::train({}, kSmall), Error);
}

TEST(Vocabulary, TrainingIsDeterministicForASeed) {
  const auto set = testing::make_synthetic_set(3);
  const Vocabulary a = Vocabulary::train(set.images, kSmall);
  const Vocabulary b = Vocabulary::train(set.images, kSmall);
  EXPECT_EQ(a.serialize(), b.serialize());
  EXPECT_EQ(a.info().seed, 7U);
  EXPECT_EQ(a.info().training_images, 30U);
  EXPECT_EQ(a.info().training_descriptors, 30U * 80U);
  EXPECT_LE(a.word_count(), 4U * 4U * 4U);
  EXPECT_GE(a.word_count(), 40U);  // 60 prototypes fill most of the 64 possible words
}

TEST(Vocabulary, ReportsProgressUpToTheDescriptorCount) {
  const auto set = testing::make_synthetic_set(3);
  std::uint64_t last = 0;
  std::uint64_t total = 0;
  bool monotonic = true;
  Vocabulary::train(set.images, kSmall, [&](std::uint64_t done, std::uint64_t t) {
    monotonic = monotonic && done >= last;
    last = done;
    total = t;
  });
  EXPECT_TRUE(monotonic);
  EXPECT_EQ(total, 2400U);
  EXPECT_EQ(last, 2400U);
}

TEST(Vocabulary, NoisyCopiesOfOnePrototypeShareAWord) {
  const auto set = testing::make_synthetic_set(3);
  const Vocabulary vocabulary = Vocabulary::train(set.images, kSmall);
  int same = 0;
  int total = 0;
  for (std::size_t i = 0; i < set.images.size(); ++i) {
    for (std::size_t k = 0; k < set.images[i].size(); ++k) {
      const auto& prototype = set.prototypes[static_cast<std::size_t>(set.prototype_of[i][k])];
      same += vocabulary.word_of(set.images[i][k]) == vocabulary.word_of(prototype) ? 1 : 0;
      ++total;
    }
  }
  EXPECT_GT(same, 0.95 * total);
}

TEST(Vocabulary, TransformGivesNormalisedVectorAndCompleteDirectIndex) {
  const auto set = testing::make_synthetic_set(3);
  const Vocabulary vocabulary = Vocabulary::train(set.images, kSmall);
  BowVector bow;
  FeatureVector features;
  vocabulary.transform(set.images[0], bow, features, 2);
  EXPECT_EQ(features.level, 2);
  double sum = 0.0;
  for (std::size_t i = 0; i < bow.entries.size(); ++i) {
    sum += bow.entries[i].weight;
    EXPECT_GE(bow.entries[i].weight, 0.0);  // 0 for a word every training image has
    if (i > 0) {
      EXPECT_LT(bow.entries[i - 1].word, bow.entries[i].word);
    }
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
  std::vector<int> seen(set.images[0].size(), 0);
  for (const auto& e : features.entries) {
    for (std::uint32_t f : e.features)
      ++seen[f];
  }
  EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
  vocabulary.transform(set.images[0], bow, features, 99);
  EXPECT_EQ(features.level, 3);  // clamped to the depth
  EXPECT_TRUE(vocabulary.transform({}).empty());
}

TEST(Vocabulary, ScoreIsSymmetricOneForIdenticalZeroForDisjoint) {
  const auto set = testing::make_synthetic_set(3);
  const Vocabulary vocabulary = Vocabulary::train(set.images, kSmall);
  std::vector<BowVector> bows;
  for (const auto& image : set.images)
    bows.push_back(vocabulary.transform(image));
  for (std::size_t i = 0; i < bows.size(); ++i) {
    EXPECT_NEAR(score_l1(bows[i], bows[i]), 1.0, 1e-12);
    for (std::size_t j = 0; j < bows.size(); ++j) {
      const double s = score_l1(bows[i], bows[j]);
      EXPECT_EQ(s, score_l1(bows[j], bows[i]));
      EXPECT_GE(s, -1e-12);
      EXPECT_LE(s, 1.0 + 1e-12);
    }
  }
  const BowVector a{{{1, 0.5}, {2, 0.5}}};
  const BowVector b{{{3, 1.0}}};
  EXPECT_EQ(score_l1(a, b), 0.0);
  const BowVector c{{{1, 0.5}, {3, 0.5}}};
  EXPECT_NEAR(score_l1(a, c), 0.5, 1e-12);
  EXPECT_EQ(score_l1(a, BowVector{}), 0.0);
}

TEST(Vocabulary, SaveLoadRoundTrip) {
  const auto set = testing::make_synthetic_set(5);
  const Vocabulary trained = Vocabulary::train(set.images, kSmall);
  const fs::path path = coloc::testing::temp_dir("bow_roundtrip") / "small.cvoc";
  trained.save(path);
  const Vocabulary loaded = Vocabulary::load(path);
  EXPECT_EQ(loaded.serialize(), trained.serialize());
  EXPECT_EQ(read_bytes(path), trained.serialize());
  EXPECT_EQ(loaded.word_count(), trained.word_count());
  EXPECT_EQ(loaded.info().training_descriptors, trained.info().training_descriptors);
  for (const auto& image : set.images) {
    const BowVector x = trained.transform(image);
    const BowVector y = loaded.transform(image);
    ASSERT_EQ(x.size(), y.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      EXPECT_EQ(x.entries[i].word, y.entries[i].word);
      EXPECT_EQ(x.entries[i].weight, y.entries[i].weight);
    }
  }
}

TEST(Vocabulary, DamagedOrForeignFilesAreRejectedWithContext) {
  const auto set = testing::make_synthetic_set(5);
  const std::vector<std::uint8_t> good = Vocabulary::train(set.images, kSmall).serialize();
  const fs::path dir = coloc::testing::temp_dir("bow_damaged");

  auto expect_error = [&](const std::string& name, const std::vector<std::uint8_t>& bytes,
                          const std::string& words) {
    const fs::path path = dir / name;
    write_bytes(path, bytes);
    const auto error = load_error(path);
    ASSERT_TRUE(error.has_value()) << name << " was accepted";
    EXPECT_EQ(error->context().file, path.string()) << name;
    EXPECT_NE(std::string(error->what()).find(words), std::string::npos)
        << name << ": " << error->what();
  };

  std::vector<std::uint8_t> flipped = good;
  flipped[flipped.size() / 2] ^= 0x10;
  expect_error("flipped.cvoc", flipped, "checksum");
  expect_error("truncated.cvoc",
               {good.begin(), good.begin() + static_cast<long>(good.size() - 100)}, "checksum");
  expect_error("header_only.cvoc", {good.begin(), good.begin() + 20}, "truncated");
  const std::string text = "%YAML:1.0\nCamera.fx: 517.3\n";
  expect_error("foreign.yaml", {text.begin(), text.end()}, "magic");
  expect_error("empty.cvoc", {}, "magic");
  std::vector<std::uint8_t> future = good;
  future[8] = 2;  // version field
  expect_error("future.cvoc", future, "version");
  EXPECT_THROW(Vocabulary::load(dir / "missing.cvoc"), Error);
  EXPECT_THROW(Vocabulary{}.save(dir / "empty_vocabulary.cvoc"), Error);
}

TEST(Vocabulary, ShippedVocabularyLoads) {
  const fs::path path = coloc::testing::source_file("Vocabulary/coloc_orb_k10_L5.cvoc");
  ASSERT_TRUE(fs::exists(path)) << path;
  const Vocabulary vocabulary = Vocabulary::load(path);
  EXPECT_EQ(vocabulary.info().branching, 10);
  EXPECT_EQ(vocabulary.info().depth, 5);
  EXPECT_GT(vocabulary.word_count(), 10000U);
  EXPECT_GT(vocabulary.info().training_images, 500U);
}

}  // namespace
}  // namespace coloc::slam::bow
