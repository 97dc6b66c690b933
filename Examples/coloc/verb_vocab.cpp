// coloc vocab train|info: our bag-of-words vocabulary from image folders, and what a file holds.
// coloc bench orb|bow: ORB extraction speed and coverage against cv::ORB; place recognition
// recall on 7-Scenes (slam/bow/place_recall.hpp).

#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/bow/place_recall.hpp"
#include "slam/bow/vocabulary.hpp"
#include "slam/core/error.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/timing.hpp"
#include "slam/dataset/image_folder.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/features/orb_extractor.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
using slam::features::OrbExtractor;
using slam::features::OrbFeatures;

// A sequence's colour image as the extractors take it (8-bit grey).
cv::Mat grey_frame(const dataset::Sequence& sequence, std::size_t index) {
  const cv::Mat colour = sequence.frame(index).color;
  if (colour.channels() == 1) return colour;
  cv::Mat grey;
  cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

// ---------------------------------------------------------------------------------------------
// vocab train / info

struct TrainArgs {
  std::vector<std::string> dirs;
  std::string out;
  slam::bow::VocabularyOptions vocabulary;
  int n_features = 1000;
  int stride = 1;
  bool quiet = false;
};

// The training images of every folder (every stride-th), with what was found and used.
std::vector<fs::path> training_images(const TrainArgs& a) {
  std::vector<fs::path> images;
  for (const std::string& dir : a.dirs) {
    const std::vector<fs::path> found = dataset::find_colour_images(dir);
    const std::vector<fs::path> used =
        dataset::every_nth(found, static_cast<std::size_t>(a.stride));
    images.insert(images.end(), used.begin(), used.end());
    std::printf("%-60s %5zu images, %5zu used\n", dir.c_str(), found.size(), used.size());
  }
  if (images.empty()) throw Error("no images found in the given folders", {.field = "DIR"});
  return images;
}

void run_train(const TrainArgs& a) {
  a.vocabulary.check();
  if (a.stride < 1) throw Error("--stride must be at least 1", {.field = "stride"});
  const std::vector<fs::path> images = training_images(a);
  OrbExtractor extractor({.n_features = a.n_features});
  std::vector<std::vector<slam::features::Descriptor>> descriptors;
  descriptors.reserve(images.size());
  std::uint64_t total = 0;
  {
    Progress progress("extract ORB", images.size(), a.quiet);
    for (const fs::path& path : images) {
      descriptors.push_back(extractor.extract(dataset::read_image(path, true)).descriptors);
      total += descriptors.back().size();
      progress.advance();
    }
    progress.finish();
  }
  Stopwatch watch;
  Progress progress("cluster", total, a.quiet);
  const auto vocabulary = slam::bow::Vocabulary::train(
      descriptors, a.vocabulary,
      [&progress](std::uint64_t done, std::uint64_t) { progress.set(done); });
  progress.finish();
  vocabulary.save(a.out);
  std::printf("trained on %zu images, %llu descriptors (%d features per image at most) in %.1f s\n",
              images.size(), static_cast<unsigned long long>(total), a.n_features,
              watch.elapsed_seconds());
  std::printf("k=%d L=%d seed=%llu: %u nodes, %u words -> %s (%llu bytes)\n",
              a.vocabulary.branching, a.vocabulary.depth,
              static_cast<unsigned long long>(a.vocabulary.seed), vocabulary.node_count(),
              vocabulary.word_count(), a.out.c_str(),
              static_cast<unsigned long long>(fs::file_size(a.out)));
}

void run_info(const std::string& file, bool json) {
  Stopwatch watch;
  const auto vocabulary = slam::bow::Vocabulary::load(file);
  const double load_ms = watch.elapsed_ms();
  const auto& i = vocabulary.info();
  if (json) {
    print_json({{"file", file},
                {"bytes", fs::file_size(file)},
                {"branching", i.branching},
                {"depth", i.depth},
                {"nodes", i.node_count},
                {"words", i.word_count},
                {"training_images", i.training_images},
                {"training_descriptors", i.training_descriptors},
                {"seed", i.seed},
                {"load_ms", load_ms}});
    return;
  }
  std::printf("file                  %s (%llu bytes)\n", file.c_str(),
              static_cast<unsigned long long>(fs::file_size(file)));
  std::printf("branching k, depth L  %d, %d\n", i.branching, i.depth);
  std::printf("nodes, words          %u, %u\n", i.node_count, i.word_count);
  std::printf("training images       %u (%llu descriptors), seed %llu\n", i.training_images,
              static_cast<unsigned long long>(i.training_descriptors),
              static_cast<unsigned long long>(i.seed));
  std::printf("weighting, scoring    TF-IDF, L1\n");
  std::printf("load time             %.1f ms\n", load_ms);
}

// ---------------------------------------------------------------------------------------------
// bench orb

struct BenchOrbArgs {
  std::string data = recordings_dir().string();
  int repeat = 3;
  bool json = false;
};

// 640x480 grey frames of TUM fr1 (xyz, every 4th of rpy) and every 10th of 7-Scenes.
std::vector<cv::Mat> bench_orb_images(const fs::path& data) {
  std::vector<cv::Mat> images;
  for (const auto& [name, step] : {std::pair<const char*, std::size_t>{"tum_fr1_xyz_37f", 1},
                                   {"tum_fr1_rpy_180f", 4},
                                   {"sevenscenes_600f", 10}}) {
    if (!fs::is_directory(data / name)) {
      spdlog::warn("bench orb: {} not found, skipped", (data / name).string());
      continue;
    }
    const auto sequence = dataset::open_sequence(data / name);
    for (std::size_t i = 0; i < sequence->size(); i += step) {
      cv::Mat grey = grey_frame(*sequence, i);
      if (grey.cols == 640 && grey.rows == 480) images.push_back(std::move(grey));
    }
  }
  if (images.empty()) throw Error("no TUM or 7-Scenes images found", {.file = data.string()});
  return images;
}

// Per-image samples of one extractor: wall and thread-CPU ms per run, coverage, feature count.
struct OrbSamples {
  std::vector<double> ms, cpu_ms, coverage, count;

  Json json() const {
    const SampleStats wall = summarize(ms), cpu = summarize(cpu_ms);
    return {{"median_ms", wall.median},
            {"p99_ms", wall.p99},
            {"cpu_median_ms", cpu.median},
            {"cpu_p99_ms", cpu.p99},
            {"coverage", summarize(coverage).mean},
            {"features", summarize(count).mean}};
  }
  void print_row(const char* name) const {
    const SampleStats wall = summarize(ms), cpu = summarize(cpu_ms);
    std::printf("%-10s %10.2f %10.2f %10.2f %10.2f %10.0f %16.3f\n", name, wall.median, wall.p99,
                cpu.median, cpu.p99, summarize(count).mean, summarize(coverage).mean);
  }
};

// Times `extract` `repeat` times on `image` (wall and CPU time of this one thread: on a shared
// machine wall time also counts the time other processes held the core).
template <typename Extract>
void time_extractor(OrbSamples& samples, int repeat, Extract&& extract) {
  for (int r = 0; r < repeat; ++r) {
    const Stopwatch wall;
    const ThreadCpuStopwatch cpu;
    extract();
    samples.ms.push_back(wall.elapsed_ms());
    samples.cpu_ms.push_back(cpu.elapsed_ms());
  }
}

void run_bench_orb(const BenchOrbArgs& a) {
  const std::vector<cv::Mat> images = bench_orb_images(a.data);
  // One core for both, so the comparison is the algorithm's, not OpenCV's thread pool.
  cv::setNumThreads(1);
  OrbExtractor ours;
  auto theirs = cv::ORB::create(1000, 1.2f, 8, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31, 20);
  OrbSamples o, t;
  for (const cv::Mat& image : images) {
    OrbFeatures f;
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    time_extractor(o, a.repeat, [&] { f = ours.extract(image); });
    time_extractor(t, a.repeat,
                   [&] { theirs->detectAndCompute(image, cv::noArray(), keypoints, descriptors); });
    std::vector<slam::features::Keypoint> converted;
    for (const auto& k : keypoints)
      converted.push_back({.x = k.pt.x, .y = k.pt.y});
    o.coverage.push_back(slam::features::grid_coverage(f.keypoints, 640, 480));
    t.coverage.push_back(slam::features::grid_coverage(converted, 640, 480));
    o.count.push_back(static_cast<double>(f.size()));
    t.count.push_back(static_cast<double>(keypoints.size()));
  }
  if (a.json) {
    print_json({{"images", images.size()},
                {"repeat", a.repeat},
                {"ours", o.json()},
                {"opencv", t.json()}});
    return;
  }
  std::printf(
      "ORB, 1000 features, 8 levels, scale 1.2, one thread; %zu images 640x480 "
      "(TUM fr1 xyz/rpy, 7-Scenes) x %d runs\n",
      images.size(), a.repeat);
  std::printf("%-10s %10s %10s %10s %10s %10s %16s\n", "", "median ms", "p99 ms", "cpu median",
              "cpu p99", "features", "coverage 16x12");
  o.print_row("coloc");
  t.print_row("cv::ORB");
  std::printf(
      "(ms: wall time; cpu: CPU time of the one thread, which excludes time other "
      "processes held the core)\n");
}

// ---------------------------------------------------------------------------------------------
// bench bow

struct BenchBowArgs {
  std::string data = recordings_dir().string();
  std::string vocabulary;  // empty: the shipped one
  slam::bow::PlaceRecallOptions recall;
  bool json = false;
};

void print_bow_recall(const BenchBowArgs& a, std::size_t frames, std::uint32_t words,
                      double load_ms, const slam::bow::PlaceRecallResult& b) {
  const double query_median_ms = summarize(b.query_ms).median;
  if (a.json) {
    print_json({{"queries", b.queries},
                {"answerable", b.answerable},
                {"database", b.database},
                {"recall_at_1", b.recall_at_1()},
                {"recall_at_5", b.recall_at_k()},
                {"query_median_ms", query_median_ms},
                {"vocabulary_load_ms", load_ms}});
    return;
  }
  const auto& o = a.recall;
  std::printf(
      "place recognition on 7-Scenes (%zu frames), vocabulary %s (%u words, loaded in "
      "%.0f ms)\n",
      frames, a.vocabulary.empty() ? "(shipped)" : a.vocabulary.c_str(), words, load_ms);
  std::printf(
      "queries: every %zu-th frame (%zu; %zu with a true match in the database); "
      "database: the other %zu frames, minus +-%zu around each query\n",
      o.query_step, b.queries, b.answerable, b.database, o.exclude);
  std::printf("hit: camera centre within %.2f m and rotation within %.0f deg\n", o.max_distance,
              o.max_angle_deg);
  std::printf("recall@1  %.3f  (%zu/%zu)\n", b.recall_at_1(), b.hit1, b.queries);
  std::printf("recall@5  %.3f  (%zu/%zu)\n", b.recall_at_k(), b.hit_k, b.queries);
  std::printf("query     %.3f ms median\n", query_median_ms);
}

void run_bench_bow(const BenchBowArgs& a) {
  a.recall.check();
  const auto sequence = dataset::open_seven_scenes(fs::path(a.data) / "sevenscenes_600f");
  const Trajectory& poses = sequence->ground_truth();
  if (poses.size() != sequence->size())
    throw Error("every 7-Scenes frame needs its pose file (frame-NNNNNN.pose.txt)",
                {.file = sequence->folder().string()});
  Stopwatch load_watch;
  const auto vocabulary = load_vocabulary(a.vocabulary);
  const double load_ms = load_watch.elapsed_ms();

  OrbExtractor extractor;
  std::vector<slam::bow::BowVector> bows;
  std::vector<SE3> world_from_cam;
  Progress progress("extract + BoW", sequence->size(), a.json);
  for (std::size_t i = 0; i < sequence->size(); ++i) {
    bows.push_back(vocabulary.transform(extractor.extract(grey_frame(*sequence, i)).descriptors));
    world_from_cam.push_back(poses[i].world_from_cam);
    progress.advance();
  }
  progress.finish();
  print_bow_recall(a, sequence->size(), vocabulary.word_count(), load_ms,
                   slam::bow::evaluate_place_recall(bows, world_from_cam, a.recall));
}

}  // namespace

void add_vocab_verb(CLI::App& app, CLI::App& bench) {
  CLI::App& vocab = *app.add_subcommand("vocab", "Bag-of-words vocabulary: train, inspect");
  vocab.require_subcommand(1);

  auto train_args = std::make_shared<TrainArgs>();
  CLI::App& train = *vocab.add_subcommand(
      "train",
      "Train a vocabulary from the ORB features of image folders (recursively; depth "
      "images skipped)");
  train.add_option("DIR", train_args->dirs, "Image or sequence folders")
      ->required()
      ->check(CLI::ExistingDirectory);
  train.add_option("--out", train_args->out, "Vocabulary file to write")->required();
  train.add_option("--branching,-k", train_args->vocabulary.branching, "Children per node")
      ->capture_default_str();
  train.add_option("--depth,-L", train_args->vocabulary.depth, "Levels of the tree")
      ->capture_default_str();
  train.add_option("--seed", train_args->vocabulary.seed, "k-means++ seed")->capture_default_str();
  train
      .add_option("--iterations", train_args->vocabulary.max_iterations,
                  "k-means iterations per node at most")
      ->capture_default_str();
  train.add_option("--features", train_args->n_features, "ORB features per image")
      ->capture_default_str();
  train.add_option("--stride", train_args->stride, "Use every n-th image of each folder")
      ->capture_default_str();
  train.add_flag("--quiet", train_args->quiet, "No progress bars");
  train.callback([train_args] { run_train(*train_args); });

  auto info_file = std::make_shared<std::string>();
  auto info_json = std::make_shared<bool>(false);
  CLI::App& info = *vocab.add_subcommand("info", "Show a vocabulary file's parameters");
  info.add_option("FILE", *info_file, "Vocabulary file")->required()->check(CLI::ExistingFile);
  info.add_flag("--json", *info_json, "Machine-readable output on stdout");
  info.callback([info_file, info_json] { run_info(*info_file, *info_json); });

  auto orb_args = std::make_shared<BenchOrbArgs>();
  CLI::App& orb = *bench.add_subcommand(
      "orb", "ORB extraction: ours vs cv::ORB, time (median/p99) and 16x12 grid coverage");
  orb.add_option("--data", orb_args->data, "Recordings folder (default $COLOC_DATA)")
      ->capture_default_str();
  orb.add_option("--repeat", orb_args->repeat, "Runs per image")->capture_default_str();
  orb.add_flag("--json", orb_args->json, "Machine-readable output on stdout");
  orb.callback([orb_args] { run_bench_orb(*orb_args); });

  auto bow_args = std::make_shared<BenchBowArgs>();
  CLI::App& bow = *bench.add_subcommand(
      "bow", "Place recognition recall@1/@5 on 7-Scenes (sevenscenes_600f) with a vocabulary");
  bow.add_option("--data", bow_args->data, "Recordings folder (default $COLOC_DATA)")
      ->capture_default_str();
  bow.add_option("--vocabulary", bow_args->vocabulary, "Vocabulary file (default: the shipped one)")
      ->check(CLI::ExistingFile);
  bow.add_option("--query-step", bow_args->recall.query_step, "Every n-th frame is a query")
      ->capture_default_str();
  bow.add_option("--exclude", bow_args->recall.exclude, "Frames around a query left out")
      ->capture_default_str();
  bow.add_flag("--json", bow_args->json, "Machine-readable output on stdout");
  bow.callback([bow_args] { run_bench_bow(*bow_args); });
}

}  // namespace coloc::cli
