// coloc vocab train|info: our bag-of-words vocabulary from image folders, and what a file holds.
// coloc bench orb|bow: ORB extraction speed and coverage against cv::ORB; place recognition
// recall on 7-Scenes.

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/bow/database.hpp"
#include "slam/bow/vocabulary.hpp"
#include "slam/core/error.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/se3.hpp"
#include "slam/core/timing.hpp"
#include "slam/features/orb_extractor.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
using slam::features::OrbExtractor;
using slam::features::OrbFeatures;

fs::path default_data_dir() {
  if (const char* env = std::getenv("COLOC_DATA"); env != nullptr && *env != '\0') return env;
  return "../shared/data";
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// Colour/grey frames under `dir` (recursively), sorted by path: .png/.jpg/.jpeg files, except
// depth images (a path component or file name containing "depth", as TUM's depth/, 7-Scenes'
// *.depth.png and RealSense's depths/ are named).
std::vector<fs::path> find_images(const fs::path& dir) {
  std::vector<fs::path> images;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    const std::string ext = lower(entry.path().extension().string());
    if (ext != ".png" && ext != ".jpg" && ext != ".jpeg") continue;
    const std::string relative = lower(fs::relative(entry.path(), dir).string());
    if (relative.find("depth") != std::string::npos) continue;
    images.push_back(entry.path());
  }
  std::sort(images.begin(), images.end());
  return images;
}

cv::Mat read_grey(const fs::path& path) {
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  if (image.empty()) throw Error("cannot read image", {.file = path.string()});
  return image;
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

void run_train(const TrainArgs& a) {
  a.vocabulary.check();
  if (a.stride < 1) throw Error("--stride must be at least 1", {.field = "stride"});
  std::vector<fs::path> images;
  for (const std::string& dir : a.dirs) {
    const std::vector<fs::path> found = find_images(dir);
    std::size_t used = 0;
    for (std::size_t i = 0; i < found.size(); i += static_cast<std::size_t>(a.stride)) {
      images.push_back(found[i]);
      ++used;
    }
    std::printf("%-60s %5zu images, %5zu used\n", dir.c_str(), found.size(), used);
  }
  if (images.empty()) throw Error("no images found in the given folders", {.field = "DIR"});

  OrbExtractor extractor({.n_features = a.n_features});
  std::vector<std::vector<slam::features::Descriptor>> descriptors;
  descriptors.reserve(images.size());
  std::uint64_t total = 0;
  {
    Progress progress("extract ORB", images.size(), a.quiet);
    for (const fs::path& path : images) {
      descriptors.push_back(extractor.extract(read_grey(path)).descriptors);
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
    std::printf(
        "{\"file\": %s, \"bytes\": %llu, \"branching\": %d, \"depth\": %d, \"nodes\": %u, "
        "\"words\": %u, \"training_images\": %u, \"training_descriptors\": %llu, \"seed\": %llu, "
        "\"load_ms\": %s}\n",
        json_string(file).c_str(), static_cast<unsigned long long>(fs::file_size(file)),
        i.branching, i.depth, i.node_count, i.word_count, i.training_images,
        static_cast<unsigned long long>(i.training_descriptors),
        static_cast<unsigned long long>(i.seed), json_number(load_ms).c_str());
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
  std::string data = default_data_dir().string();
  int repeat = 3;
  bool json = false;
};

// CPU time of the calling thread (ms). On a shared machine wall time also counts the time other
// processes held the core; both extractors run on this thread only (cv::setNumThreads(1)).
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

std::vector<fs::path> every_nth(const std::vector<fs::path>& v, std::size_t n) {
  std::vector<fs::path> out;
  for (std::size_t i = 0; i < v.size(); i += n)
    out.push_back(v[i]);
  return out;
}

// 640x480 frames of TUM fr1 (xyz, every 4th of rpy) and every 10th of 7-Scenes.
std::vector<fs::path> bench_orb_images(const fs::path& data) {
  std::vector<fs::path> images;
  for (const auto& [dir, step] : {std::pair<const char*, std::size_t>{"tum_fr1_xyz_37f/rgb", 1},
                                  {"tum_fr1_rpy_180f/rgb", 4},
                                  {"sevenscenes_600f", 10}}) {
    if (!fs::is_directory(data / dir)) {
      spdlog::warn("bench orb: {} not found, skipped", (data / dir).string());
      continue;
    }
    const auto found = every_nth(find_images(data / dir), step);
    images.insert(images.end(), found.begin(), found.end());
  }
  if (images.empty()) throw Error("no TUM or 7-Scenes images found", {.file = data.string()});
  return images;
}

void run_bench_orb(const BenchOrbArgs& a) {
  const std::vector<fs::path> images = bench_orb_images(a.data);

  // One core for both, so the comparison is the algorithm's, not OpenCV's thread pool.
  cv::setNumThreads(1);
  OrbExtractor ours;
  auto theirs = cv::ORB::create(1000, 1.2f, 8, 31, 0, 2, cv::ORB::HARRIS_SCORE, 31, 20);
  std::vector<double> ours_ms;
  std::vector<double> theirs_ms;
  std::vector<double> ours_cpu_ms;
  std::vector<double> theirs_cpu_ms;
  std::vector<double> ours_coverage;
  std::vector<double> theirs_coverage;
  std::vector<double> ours_count;
  std::vector<double> theirs_count;
  for (const fs::path& path : images) {
    const cv::Mat image = read_grey(path);
    if (image.cols != 640 || image.rows != 480) continue;
    OrbFeatures f;
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    for (int r = 0; r < a.repeat; ++r) {
      Stopwatch w;
      double cpu = thread_cpu_ms();
      f = ours.extract(image);
      ours_ms.push_back(w.elapsed_ms());
      ours_cpu_ms.push_back(thread_cpu_ms() - cpu);
      w.restart();
      cpu = thread_cpu_ms();
      theirs->detectAndCompute(image, cv::noArray(), keypoints, descriptors);
      theirs_ms.push_back(w.elapsed_ms());
      theirs_cpu_ms.push_back(thread_cpu_ms() - cpu);
    }
    std::vector<slam::features::Keypoint> converted;
    for (const auto& k : keypoints)
      converted.push_back({.x = k.pt.x, .y = k.pt.y});
    ours_coverage.push_back(slam::features::grid_coverage(f.keypoints, 640, 480));
    theirs_coverage.push_back(slam::features::grid_coverage(converted, 640, 480));
    ours_count.push_back(static_cast<double>(f.size()));
    theirs_count.push_back(static_cast<double>(keypoints.size()));
  }
  const SampleStats o = summarize(ours_ms);
  const SampleStats t = summarize(theirs_ms);
  const SampleStats oc_ms = summarize(ours_cpu_ms);
  const SampleStats tc_ms = summarize(theirs_cpu_ms);
  const double oc = summarize(ours_coverage).mean;
  const double tc = summarize(theirs_coverage).mean;
  if (a.json) {
    std::printf(
        "{\"images\": %zu, \"repeat\": %d, \"ours\": {\"median_ms\": %s, \"p99_ms\": %s, "
        "\"cpu_median_ms\": %s, \"cpu_p99_ms\": %s, \"coverage\": %s, \"features\": %s}, "
        "\"opencv\": {\"median_ms\": %s, \"p99_ms\": %s, \"cpu_median_ms\": %s, "
        "\"cpu_p99_ms\": %s, \"coverage\": %s, \"features\": %s}}\n",
        ours_coverage.size(), a.repeat, json_number(o.median).c_str(), json_number(o.p99).c_str(),
        json_number(oc_ms.median).c_str(), json_number(oc_ms.p99).c_str(), json_number(oc).c_str(),
        json_number(summarize(ours_count).mean).c_str(), json_number(t.median).c_str(),
        json_number(t.p99).c_str(), json_number(tc_ms.median).c_str(),
        json_number(tc_ms.p99).c_str(), json_number(tc).c_str(),
        json_number(summarize(theirs_count).mean).c_str());
    return;
  }
  std::printf(
      "ORB, 1000 features, 8 levels, scale 1.2, one thread; %zu images 640x480 "
      "(TUM fr1 xyz/rpy, 7-Scenes) x %d runs\n",
      ours_coverage.size(), a.repeat);
  std::printf("%-10s %10s %10s %10s %10s %10s %16s\n", "", "median ms", "p99 ms", "cpu median",
              "cpu p99", "features", "coverage 16x12");
  std::printf("%-10s %10.2f %10.2f %10.2f %10.2f %10.0f %16.3f\n", "coloc", o.median, o.p99,
              oc_ms.median, oc_ms.p99, summarize(ours_count).mean, oc);
  std::printf("%-10s %10.2f %10.2f %10.2f %10.2f %10.0f %16.3f\n", "cv::ORB", t.median, t.p99,
              tc_ms.median, tc_ms.p99, summarize(theirs_count).mean, tc);
  std::printf(
      "(ms: wall time; cpu: CPU time of the one thread, which excludes time other "
      "processes held the core)\n");
}

// ---------------------------------------------------------------------------------------------
// bench bow

struct BenchBowArgs {
  std::string data = default_data_dir().string();
  std::string vocabulary = "Vocabulary/coloc_orb_k10_L5.cvoc";
  int query_step = 10;
  int exclude = 15;
  double max_distance = 0.3;
  double max_angle_deg = 20.0;
  bool json = false;
};

// 7-Scenes frame-NNNNNN.pose.txt: a 4x4 camera-to-world matrix, row-major.
SE3 read_seven_scenes_pose(const fs::path& path) {
  std::ifstream in(path);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      if (!(in >> m(r, c))) throw Error("malformed 4x4 pose", {.file = path.string()});
    }
  }
  return SE3::from_matrix(m);
}

std::vector<fs::path> seven_scenes_frames(const fs::path& dir) {
  std::vector<fs::path> frames;
  for (const fs::path& p : find_images(dir)) {
    if (p.filename().string().find(".color.") != std::string::npos) frames.push_back(p);
  }
  if (frames.empty()) throw Error("no 7-Scenes colour frames found", {.file = dir.string()});
  return frames;
}

struct BowRecall {
  std::size_t frames;
  std::uint32_t words;
  double load_ms;
  std::size_t queries;
  std::size_t answerable;  // queries with a true match in their database
  std::size_t database;
  std::size_t hit1;
  std::size_t hit5;
  double query_median_ms;
};

void print_bow_recall(const BenchBowArgs& a, const BowRecall& b) {
  const double r1 = static_cast<double>(b.hit1) / static_cast<double>(b.queries);
  const double r5 = static_cast<double>(b.hit5) / static_cast<double>(b.queries);
  if (a.json) {
    std::printf(
        "{\"queries\": %zu, \"answerable\": %zu, \"database\": %zu, \"recall_at_1\": %s, "
        "\"recall_at_5\": %s, \"query_median_ms\": %s, \"vocabulary_load_ms\": %s}\n",
        b.queries, b.answerable, b.database, json_number(r1).c_str(), json_number(r5).c_str(),
        json_number(b.query_median_ms).c_str(), json_number(b.load_ms).c_str());
    return;
  }
  std::printf(
      "place recognition on 7-Scenes (%zu frames), vocabulary %s (%u words, loaded in "
      "%.0f ms)\n",
      b.frames, a.vocabulary.c_str(), b.words, b.load_ms);
  std::printf(
      "queries: every %d-th frame (%zu; %zu with a true match in the database); "
      "database: the other %zu frames, minus +-%d around each query\n",
      a.query_step, b.queries, b.answerable, b.database, a.exclude);
  std::printf("hit: camera centre within %.2f m and rotation within %.0f deg\n", a.max_distance,
              a.max_angle_deg);
  std::printf("recall@1  %.3f  (%zu/%zu)\n", r1, b.hit1, b.queries);
  std::printf("recall@5  %.3f  (%zu/%zu)\n", r5, b.hit5, b.queries);
  std::printf("query     %.3f ms median\n", b.query_median_ms);
}

void run_bench_bow(const BenchBowArgs& a) {
  const std::vector<fs::path> frames = seven_scenes_frames(fs::path(a.data) / "sevenscenes_600f");
  Stopwatch load_watch;
  const auto vocabulary = slam::bow::Vocabulary::load(a.vocabulary);
  const double load_ms = load_watch.elapsed_ms();

  OrbExtractor extractor;
  std::vector<slam::bow::BowVector> bows(frames.size());
  std::vector<SE3> world_from_cam(frames.size());
  {
    Progress progress("extract + BoW", frames.size(), a.json);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      bows[i] = vocabulary.transform(extractor.extract(read_grey(frames[i])).descriptors);
      std::string stem = frames[i].string();
      stem = stem.substr(0, stem.find(".color."));
      world_from_cam[i] = read_seven_scenes_pose(stem + ".pose.txt");
      progress.advance();
    }
    progress.finish();
  }
  const auto step = static_cast<std::size_t>(a.query_step);
  slam::bow::BowDatabase database;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (i % step != 0) database.add(i, bows[i]);
  }
  auto is_hit = [&](std::size_t q, std::size_t d) {
    const SE3 q_from_d = world_from_cam[q].inverse() * world_from_cam[d];
    return q_from_d.translation().norm() <= a.max_distance &&
           q_from_d.so3().log().norm() <= a.max_angle_deg * M_PI / 180.0;
  };
  std::size_t queries = 0;
  std::size_t answerable = 0;
  std::size_t hit1 = 0;
  std::size_t hit5 = 0;
  std::vector<double> query_ms;
  for (std::size_t q = 0; q < frames.size(); q += step) {
    ++queries;
    auto far = [&](std::uint64_t d) {
      return d + static_cast<std::uint64_t>(a.exclude) < q ||
             d > q + static_cast<std::uint64_t>(a.exclude);
    };
    bool any_positive = false;
    for (std::size_t d = 0; d < frames.size(); ++d) {
      any_positive = any_positive || (d % step != 0 && far(d) && is_hit(q, d));
    }
    answerable += any_positive ? 1 : 0;
    slam::bow::QueryOptions options;
    options.max_results = 5;
    options.accept = far;
    Stopwatch w;
    const auto results = database.query(bows[q], options);
    query_ms.push_back(w.elapsed_ms());
    for (std::size_t r = 0; r < results.size(); ++r) {
      if (!is_hit(q, results[r].image)) continue;
      hit1 += r == 0 ? 1 : 0;
      ++hit5;
      break;
    }
  }
  print_bow_recall(a, {frames.size(), vocabulary.word_count(), load_ms, queries, answerable,
                       database.size(), hit1, hit5, summarize(query_ms).median});
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
  orb.add_option("--data", orb_args->data, "Shared data folder")->capture_default_str();
  orb.add_option("--repeat", orb_args->repeat, "Runs per image")->capture_default_str();
  orb.add_flag("--json", orb_args->json, "Machine-readable output on stdout");
  orb.callback([orb_args] { run_bench_orb(*orb_args); });

  auto bow_args = std::make_shared<BenchBowArgs>();
  CLI::App& bow = *bench.add_subcommand(
      "bow", "Place recognition recall@1/@5 on 7-Scenes (sevenscenes_600f) with a vocabulary");
  bow.add_option("--data", bow_args->data, "Shared data folder")->capture_default_str();
  bow.add_option("--vocabulary", bow_args->vocabulary, "Vocabulary file")
      ->capture_default_str()
      ->check(CLI::ExistingFile);
  bow.add_option("--query-step", bow_args->query_step, "Every n-th frame is a query")
      ->capture_default_str();
  bow.add_option("--exclude", bow_args->exclude, "Frames around a query left out")
      ->capture_default_str();
  bow.add_flag("--json", bow_args->json, "Machine-readable output on stdout");
  bow.callback([bow_args] { run_bench_bow(*bow_args); });
}

}  // namespace coloc::cli
