// `edgefusion eval ate|rpe|labels`: trajectory and label evaluation (TUM and SemanticFusion conventions).
#include <cstdio>
#include <string>

#include "args.h"
#include "commands.h"
#include "eval/label_eval.h"
#include "eval/trajectory_eval.h"

namespace ef::app {

namespace {

const std::vector<OptionSpec> kAteOptions = {
    {"--max-dt", "SECONDS", "largest time gap between associated poses, seconds; default 0.02"}};
const std::vector<OptionSpec> kRpeOptions = {
    {"--delta-frames", "K", "frame distance of the relative poses compared", true},
    {"--max-dt", "SECONDS", "largest time gap between associated poses, seconds; default 0.02"}};
const std::vector<OptionSpec> kLabelOptions = {
    {"--depth", "DIR", "16-bit depth PNGs with the same stems; pixels with 0 depth are excluded"},
    {"--every", "K", "evaluate every K-th ground-truth image in name order; default 1"}};

void print_eval_help() {
  std::printf(
      "Usage: edgefusion eval <ate|rpe|labels> ...   (edgefusion eval <kind> --help for each)\n\n"
      "  ate GT EST [--max-dt 0.02]            absolute trajectory error after rigid alignment (Horn);\n"
      "                                        prints ate_rmse_m, ate_mean_m, ate_max_m, pairs\n"
      "  rpe GT EST --delta-frames K           relative pose error over K frames (translation m, rotation deg)\n"
      "  labels GT_DIR EST_DIR [--depth DIR] [--every K]\n"
      "                                        per-class accuracy, class average, pixel average and mIoU\n"
      "                                        over the 13 NYUv2 classes; unknown ground truth excluded\n"
      "GT and EST trajectories are TUM files (timestamp tx ty tz qx qy qz qw, camera to world).\n");
}

// --max-dt: poses pair when their times differ by less than it, so 0 would pair none (not even
// equal times): refused, as anything outside (0, 10] s.
Result<double> positive_max_dt(const ParsedArgs& args) {
  auto v = args.get_double("--max-dt", 0.02, 0.0, 10.0);
  if (v.ok() && !(*v > 0.0))
    return error(ErrorCode::kInvalidArgument, "--max-dt " + args.get("--max-dt") +
                                                  ": poses pair when their times differ by less than this; give a "
                                                  "positive number of seconds (default 0.02)");
  return v;
}

int eval_ate(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion eval ate";
  if (wants_help(argc, argv, 3)) {
    std::printf("%s", format_help("edgefusion eval ate GT EST [--max-dt 0.02]",
                                  "Absolute trajectory error of EST against GT (TUM files) after a least-squares\n"
                                  "rigid alignment of the associated positions.",
                                  kAteOptions).c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kAteOptions, 2, argc, argv, 3);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  auto max_dt = positive_max_dt(*args);
  if (!max_dt.ok()) return report_error(kCmd, max_dt.error(), 2);
  auto r = evaluate_ate_files(args->positionals()[0], args->positionals()[1], *max_dt);
  if (!r.ok()) return report_error(kCmd, r.error(), 1);
  if (!r->warnings.empty()) std::fprintf(stderr, "%s: warning: %s", kCmd, r->warnings.c_str());
  std::printf("%s", format_ate(*r).c_str());
  return 0;
}

int eval_rpe(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion eval rpe";
  if (wants_help(argc, argv, 3)) {
    std::printf("%s", format_help("edgefusion eval rpe GT EST --delta-frames K [--max-dt 0.02]",
                                  "Relative pose error between poses K frames apart (TUM files).", kRpeOptions)
                          .c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kRpeOptions, 2, argc, argv, 3);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  auto delta = args->get_int("--delta-frames", 1, 1, 1000000);
  if (!delta.ok()) return report_error(kCmd, delta.error(), 2);
  auto max_dt = positive_max_dt(*args);
  if (!max_dt.ok()) return report_error(kCmd, max_dt.error(), 2);
  auto r = evaluate_rpe_files(args->positionals()[0], args->positionals()[1], static_cast<int>(*delta), *max_dt);
  if (!r.ok()) return report_error(kCmd, r.error(), 1);
  if (!r->warnings.empty()) std::fprintf(stderr, "%s: warning: %s", kCmd, r->warnings.c_str());
  std::printf("%s", format_rpe(*r).c_str());
  return 0;
}

int eval_labels(int argc, char** argv) {
  constexpr const char* kCmd = "edgefusion eval labels";
  if (wants_help(argc, argv, 3)) {
    std::printf("%s", format_help("edgefusion eval labels GT_DIR EST_DIR [--depth DIR] [--every K]",
                                  "Compares class-id PNGs matched by file name (0 = unknown, 1..13 the NYUv2\n"
                                  "classes). Ground-truth unknown pixels and pixels without depth are excluded.",
                                  kLabelOptions).c_str());
    return 0;
  }
  auto args = parse_args(kCmd, kLabelOptions, 2, argc, argv, 3);
  if (!args.ok()) return report_error(kCmd, args.error(), 2);
  LabelEvalOptions options;
  options.depth_dir = args->get("--depth");
  auto every = args->get_int("--every", 1, 1, 1000000);
  if (!every.ok()) return report_error(kCmd, every.error(), 2);
  options.every = static_cast<int>(*every);
  auto r = evaluate_labels(args->positionals()[0], args->positionals()[1], options);
  if (!r.ok()) return report_error(kCmd, r.error(), 1);
  std::printf("%s", format_label_report(*r).c_str());
  return 0;
}

}  // namespace

int cmd_eval(int argc, char** argv) {
  if (argc < 3 || std::string(argv[2]) == "--help" || std::string(argv[2]) == "-h") {
    print_eval_help();
    return argc < 3 ? 2 : 0;
  }
  const std::string kind = argv[2];
  if (kind == "ate") return eval_ate(argc, argv);
  if (kind == "rpe") return eval_rpe(argc, argv);
  if (kind == "labels") return eval_labels(argc, argv);
  std::fprintf(stderr, "edgefusion eval: unknown kind '%s' (expected ate, rpe or labels)\n", kind.c_str());
  return 2;
}

const std::vector<OptionSpec>& eval_ate_options() { return kAteOptions; }
const std::vector<OptionSpec>& eval_rpe_options() { return kRpeOptions; }
const std::vector<OptionSpec>& eval_labels_options() { return kLabelOptions; }

}  // namespace ef::app
