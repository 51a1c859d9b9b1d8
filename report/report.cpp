#include "report/report.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "report/html.h"
#include "report/svg_plot.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string_view>

namespace facesynth::report {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
namespace layout = evals_layout;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// Warnings go to the page (next to the section they concern) and to the caller.
struct Context {
    HtmlPage& page;
    Report& report;
    void warn(const std::string& line) {
        report.warnings.push_back(line);
        page.note("Could not use " + line);
    }
};

std::string fixed(double v, int decimals = 2) {
    if (!std::isfinite(v)) return "–";
    char text[48];
    std::snprintf(text, sizeof text, "%.*f", decimals, v);
    return text;
}

std::string percent(double share, int decimals = 1) { return std::isfinite(share) ? fixed(100 * share, decimals) + " %" : "–"; }

double number_at(const json& j, const std::string& key) {
    const auto it = j.find(key);
    if (it == j.end() || !it->is_number()) return kNan;
    const double v = it->get<double>();
    return v;
}

std::string text_at(const json& j, const std::string& key) {
    const auto it = j.find(key);
    if (it == j.end()) return "–";
    if (it->is_string()) return it->get<std::string>();
    if (it->is_boolean()) return it->get<bool>() ? "yes" : "no";
    return it->dump();
}

std::optional<json> load_json(const fs::path& path, Context& context) {
    try {
        json j = json::parse(core::read_file(path));
        if (!j.is_object()) throw core::Error("not a JSON object");
        return j;
    } catch (const json::exception& e) {
        context.warn(path.string() + ": invalid JSON (" + e.what() + ")");
    } catch (const core::Error& e) {
        context.warn(std::string(e.what()));
    }
    return std::nullopt;
}

// A small CSV with a header row and no quoting (the files our commands write).
struct Csv {
    std::vector<std::string> header;
    std::vector<std::vector<std::string>> rows;
    [[nodiscard]] int column(std::string_view name) const {
        const auto it = std::find(header.begin(), header.end(), name);
        return it == header.end() ? -1 : static_cast<int>(it - header.begin());
    }
};

// Fields of one CSV line (RFC 4180 quoting; no line breaks inside fields).
std::vector<std::string> split_csv_line(const std::string& line) {
    std::vector<std::string> cells(1);
    bool quoted = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
        const char c = line[i];
        if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') cells.back() += '"', ++i;
        else if (c == '"') quoted = !quoted;
        else if (c == ',' && !quoted) cells.emplace_back();
        else cells.back() += c;
    }
    return cells;
}

Csv read_csv(const fs::path& path) {
    std::stringstream stream(core::read_file(path));
    Csv csv;
    std::string line;
    int number = 0;
    while (std::getline(stream, line)) {
        ++number;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty()) continue;
        auto cells = split_csv_line(line);
        if (csv.header.empty()) {
            csv.header = std::move(cells);
            continue;
        }
        if (cells.size() != csv.header.size())
            throw core::file_error(path.string(), "line " + std::to_string(number) + " has " + std::to_string(cells.size()) + " fields, the header " +
                                                std::to_string(csv.header.size()));
        csv.rows.push_back(std::move(cells));
    }
    if (csv.header.empty()) throw core::file_error(path.string(), "empty CSV");
    return csv;
}

double parse_number(const std::string& text, const fs::path& path) {
    if (text == "inf") return std::numeric_limits<double>::infinity();
    try {
        std::size_t used = 0;
        const double v = std::stod(text, &used);
        if (used == text.size()) return v;
    } catch (const std::exception&) {
    }
    throw core::file_error(path.string(), "'" + text + "' is not a number");
}

std::vector<fs::path> files_matching(const fs::path& dir, std::string_view prefix, std::string_view suffix) {
    std::vector<fs::path> found;
    std::error_code error;
    if (dir.empty() || !fs::is_directory(dir, error)) return found;
    for (const auto& entry : fs::directory_iterator(dir, error)) {
        const std::string name = entry.path().filename().string();
        if (entry.is_regular_file() && name.size() > prefix.size() + suffix.size() && name.starts_with(prefix) && name.ends_with(suffix))
            found.push_back(entry.path());
    }
    std::sort(found.begin(), found.end());
    return found;
}

// "eval_fit_contour.json" with prefix "eval_fit_" -> "contour".
std::string name_between(const fs::path& file, std::string_view prefix, std::string_view suffix) {
    const std::string name = file.filename().string();
    return name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
}

// Keys "<prefix>yaw_<lo>_<hi>_<metric>" grouped by bin, bins in ascending order.
struct Bin {
    int low = 0;
    int high = 0;
    std::map<std::string, double> metrics;
    [[nodiscard]] std::string label() const { return std::to_string(low) + "–" + std::to_string(high) + "°"; }
    [[nodiscard]] double centre() const { return 0.5 * (low + high); }
    [[nodiscard]] double at(const std::string& metric) const {
        const auto it = metrics.find(metric);
        return it == metrics.end() ? kNan : it->second;
    }
};

// Takes a decimal integer (with an optional minus sign) off the front of `text`.
std::optional<int> take_int(std::string_view& text) {
    int value = 0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (error != std::errc() || end == text.data()) return std::nullopt;
    text.remove_prefix(static_cast<std::size_t>(end - text.data()));
    return value;
}

// Takes `literal` off the front of `text` when it is there.
bool take(std::string_view& text, std::string_view literal) {
    if (!text.starts_with(literal)) return false;
    text.remove_prefix(literal.size());
    return true;
}

std::vector<Bin> yaw_bins(const json& j, const std::string& prefix = "") {
    std::map<std::pair<int, int>, Bin> bins;
    for (const auto& [key, value] : j.items()) {
        if (!key.starts_with(prefix) || !value.is_number()) continue;
        // yaw_<lo>_<hi>_<metric>
        std::string_view rest(key);
        rest.remove_prefix(prefix.size());
        if (!take(rest, "yaw_")) continue;
        const auto low = take_int(rest);
        if (!low || !take(rest, "_")) continue;
        const auto high = take_int(rest);
        if (!high || !take(rest, "_") || rest.empty()) continue;
        Bin& bin = bins[{*low, *high}];
        bin.low = *low;
        bin.high = *high;
        bin.metrics[std::string(rest)] = value.get<double>();
    }
    std::vector<Bin> out;
    out.reserve(bins.size());
    for (auto& [range, bin] : bins) out.push_back(std::move(bin));
    return out;
}

// Inline SVG needs no namespace declaration, and leaving it out keeps the page free of URLs.
std::string inline_svg(std::string svg) {
    static constexpr std::string_view kNamespace = " xmlns=\"http://www.w3.org/2000/svg\"";
    if (const auto at = svg.find(kNamespace); at != std::string::npos) svg.erase(at, kNamespace.size());
    return svg;
}

double max_of(const std::vector<Series>& series, double floor_value) {
    double top = floor_value;
    for (const auto& s : series)
        for (double v : s.y)
            if (std::isfinite(v)) top = std::max(top, v);
    return top;
}

// ---------------------------------------------------------------- sections

void samples_section(const ReportInputs& inputs, Context& context) {
    HtmlPage& page = context.page;
    page.section("samples", "Generated samples");
    if (inputs.dataset.empty()) {
        page.missing("no synthetic dataset was given (--dataset DIR)",
                     "facesynth synth --model builtin --out DIR --count 64, then facesynth report --dataset DIR");
        context.report.sections_missing.emplace_back("samples");
        return;
    }
    if (const auto info = load_json(inputs.dataset / "dataset.json", context)) {
        page.paragraph("Dataset " + inputs.dataset.string() + ": " + text_at(*info, "count") + " samples of model '" + text_at(*info, "model_name") +
                       "' (checksum " + text_at(*info, "model_checksum") + "), seed " + text_at(*info, "seed") + ", facesynth " +
                       text_at(*info, "tool_version") + ".");
    }
    if (!inputs.contact_sheet || inputs.contact_sheet->empty()) {
        page.missing("the contact sheet of " + inputs.dataset.string(), "facesynth synth sheet " + inputs.dataset.string() + " --out sheet.png");
        context.report.sections_missing.emplace_back("samples");
        return;
    }
    cv::Mat bgr;
    cv::cvtColor(*inputs.contact_sheet, bgr, cv::COLOR_RGB2BGR);
    page.paragraph("The first samples with their landmarks: green visible, red self-occluded, orange covered by an occluder; each tile "
                   "names its sample key and yaw.");
    page.raw("<div class=\"sheet\">" + img_tag(bgr, ImageCoding::kJpeg, "contact sheet of " + inputs.dataset.filename().string()) + "</div>\n");
    context.report.sections_shown.emplace_back("samples");
}

void fit_results_table(const std::vector<std::pair<std::string, json>>& runs, HtmlPage& page) {
    std::vector<std::vector<std::string>> rows;
    for (const auto& [name, j] : runs) {
        const double rmse = number_at(j, "vertex_rmse_mm"), mean_shape = number_at(j, "vertex_rmse_mm_meanshape");
        rows.push_back({name, text_at(j, "mode"), text_at(j, "landmarks"), fixed(number_at(j, "noise_px"), 1), text_at(j, "refine"),
                        text_at(j, "count"), text_at(j, "failed"), fixed(number_at(j, "yaw_mae_deg")), fixed(number_at(j, "pitch_mae_deg")),
                        fixed(number_at(j, "roll_mae_deg")), fixed(rmse), fixed(mean_shape),
                        std::isfinite(rmse) && mean_shape > 0 ? fixed(100 * (rmse / mean_shape - 1), 0) + " %" : "–",
                        fixed(number_at(j, "cpu_ms_per_fit"))});
    }
    page.table({"run", "jaw", "landmarks", "noise px", "refined", "faces", "failed", "yaw MAE °", "pitch MAE °", "roll MAE °", "vertex RMSE mm",
                "mean shape mm", "vs mean shape", "CPU ms/fit"},
               rows);
}

void fit_section(const fs::path& evals, Context& context) {
    HtmlPage& page = context.page;
    page.section("fit", "3DMM fitting accuracy");
    std::vector<std::pair<std::string, json>> runs;
    for (const auto& file : files_matching(evals, layout::kFitPrefix, ".json"))
        if (auto j = load_json(file, context)) runs.emplace_back(name_between(file, layout::kFitPrefix, ".json"), std::move(*j));
    bool shown = false;
    if (runs.empty()) {
        page.missing("fit results (" + std::string(layout::kFitPrefix) + "<name>.json in the results folder)",
                     "facesynth eval fit --model builtin --data DATASET --mode contour --refine --json EVALS/eval_fit_contour.json");
    } else {
        page.paragraph("Fits from the rendered faces' true 2D landmarks, against the true pose and identity shape (docs/fit.md). "
                       "\"vs mean shape\" is the identity error relative to predicting the model's mean face.");
        fit_results_table(runs, page);
        std::vector<std::string> plots;
        for (const auto& [metric, title] : {std::pair<std::string, std::string>{"vertex_rmse_mm", "identity vertex RMSE (mm)"},
                                            {"yaw_mae_deg", "yaw error (° MAE)"}}) {
            LinePlot plot;
            plot.title = title + " by yaw";
            plot.x = linear_axis("true yaw (°), 15° bins", -90, 90);
            double low = 90, high = -90;
            for (const auto& [name, j] : runs) {
                Series s;
                s.label = name;
                s.markers = true;
                for (const Bin& bin : yaw_bins(j)) {
                    if (number_at(j, "yaw_" + std::to_string(bin.low) + "_" + std::to_string(bin.high) + "_count") == 0) continue;
                    s.x.push_back(bin.centre());
                    s.y.push_back(bin.at(metric));
                    low = std::min(low, static_cast<double>(bin.low));
                    high = std::max(high, static_cast<double>(bin.high));
                }
                plot.series.push_back(std::move(s));
            }
            if (low < high) {
                std::vector<double> ticks;
                for (double t = std::ceil(low / 30) * 30; t <= high; t += 30) ticks.push_back(t);
                plot.x = linear_axis(plot.x.label, low, high, ticks);
            }
            plot.y = linear_axis(title, 0, max_of(plot.series, 1e-3) * 1.1);
            plots.push_back(inline_svg(line_plot_svg(plot)));
        }
        page.figures(plots);
        shown = true;
    }

    page.subheading("Error against the number of landmarks and their noise");
    const fs::path sweep_dir = evals.empty() ? fs::path() : evals / layout::kFitSweepDir;
    std::map<int, std::map<double, json>> sweep;  // landmark count -> noise -> result
    for (const auto& file : files_matching(sweep_dir, "eval_", ".json")) {
        // eval_<landmarks>_<noise>.json
        const std::string name = file.filename().string();
        std::string_view rest(name);
        if (!take(rest, "eval_")) continue;
        const auto landmarks = take_int(rest);
        if (!landmarks || *landmarks < 0 || !take(rest, "_") || !rest.ends_with(".json")) continue;
        const std::string noise(rest.substr(0, rest.size() - 5));
        if (noise.empty() || noise.find_first_not_of("0123456789.") != std::string::npos) continue;
        if (auto j = load_json(file, context)) sweep[*landmarks][std::stod(noise)] = std::move(*j);
    }
    if (sweep.empty()) {
        page.missing("the landmark-count and noise sweep (" + std::string(layout::kFitSweepDir) + "/eval_<landmarks>_<noise>.json)",
                     "tools/fit_sweep.py build/facesynth builtin EVALS/" + std::string(layout::kFitSweepDir) + " --count 200 --refine");
    } else {
        std::vector<std::string> plots;
        for (const auto& [metric, title] : {std::pair<std::string, std::string>{"vertex_rmse_mm", "identity vertex RMSE (mm)"},
                                            {"yaw_mae_deg", "yaw error (° MAE)"}}) {
            LinePlot plot;
            plot.title = title;
            double noise_max = 0;
            for (const auto& [count, by_noise] : sweep) {
                Series s;
                s.label = std::to_string(count) + " landmarks";
                s.markers = true;
                for (const auto& [noise, j] : by_noise) {
                    s.x.push_back(noise);
                    s.y.push_back(number_at(j, metric));
                    noise_max = std::max(noise_max, noise);
                }
                plot.series.push_back(std::move(s));
            }
            plot.x = linear_axis("landmark noise (px, standard deviation)", 0, std::max(noise_max, 1.0));
            plot.y = linear_axis(title, 0, max_of(plot.series, 1e-3) * 1.1);
            plots.push_back(inline_svg(line_plot_svg(plot)));
        }
        page.figures(plots);
        shown = true;
    }
    (shown ? context.report.sections_shown : context.report.sections_missing).emplace_back("fit");
}

// Regressor specs name files; the report shows the file name only.
std::string short_regressor_label(const std::string& spec) {
    const auto colon = spec.find(':');
    const std::string kind = colon == std::string::npos ? "" : spec.substr(0, colon + 1);
    const std::string path = colon == std::string::npos ? spec : spec.substr(colon + 1);
    return kind + fs::path(path).filename().string();
}

void landmarks_section(const fs::path& evals, Context& context) {
    HtmlPage& page = context.page;
    page.section("landmarks", "Landmark detection");
    const auto files = files_matching(evals, layout::kLandmarksPrefix, ".json");
    if (files.empty()) {
        page.missing("landmark results (" + std::string(layout::kLandmarksPrefix) + "<name>.json in the results folder)",
                     "facesynth eval landmarks --regressor MODEL.sdm --regressor dlib --data DATASET --json EVALS/eval_landmarks_synthetic.json "
                     "--nme-csv EVALS/eval_landmarks_synthetic.nme.csv");
        context.report.sections_missing.emplace_back("landmarks");
        return;
    }
    page.paragraph("NME: mean point-to-point error over the 68 points divided by the outer-eye-corner distance; faces the face detector "
                   "misses count as failures. The first regressor is ours; the others are baselines on the same face boxes.");
    std::vector<std::string> plots;
    for (const auto& file : files) {
        const auto j = load_json(file, context);
        if (!j) continue;
        const std::string name = name_between(file, layout::kLandmarksPrefix, ".json");
        const std::string detector = j->contains("detector") ? text_at(*j, "detector") + " " : "";
        page.subheading("Test set: " + name + " (" + text_at(*j, "count") + " faces, " + text_at(*j, "detector_misses") + " " + detector +
                        "detector misses)");
        std::vector<std::vector<std::string>> rows;
        std::vector<std::string> labels;
        for (int r = 1; j->contains("regressor" + std::to_string(r)); ++r) {
            const std::string prefix = r == 1 ? "" : "regressor" + std::to_string(r) + "_";
            labels.push_back(short_regressor_label(text_at(*j, "regressor" + std::to_string(r))));
            // eval landmarks writes an infinite value (more than half the faces missed) as -1.
            const auto nme = [&](const std::string& key) {
                const double v = number_at(*j, prefix + key);
                return v < 0 ? std::string("∞") : fixed(v, 4);
            };
            rows.push_back({labels.back(), nme("nme_mean"), nme("nme_median"),
                            fixed(number_at(*j, prefix + "auc_008"), 4), percent(number_at(*j, prefix + "failure_rate_008")),
                            fixed(number_at(*j, prefix + "ms_per_face"))});
        }
        page.table({"regressor", "NME mean", "NME median", "AUC@0.08", "failures (NME > 0.08)", "ms/face"}, rows);

        const fs::path csv_path = evals / (std::string(layout::kLandmarksPrefix) + name + layout::kNmeCsvSuffix);
        if (!fs::exists(csv_path)) {
            page.missing("per-face NMEs for the CED curve (" + csv_path.filename().string() + ")",
                         "facesynth eval landmarks … --json " + file.filename().string() + " --nme-csv " + csv_path.filename().string());
            continue;
        }
        try {
            const Csv csv = read_csv(csv_path);
            LinePlot plot = ced_plot("CED, " + name);
            for (int r = 1;; ++r) {
                const int column = csv.column("regressor" + std::to_string(r));
                if (column < 0) break;
                std::vector<double> nmes;
                for (const auto& row : csv.rows) nmes.push_back(parse_number(row[static_cast<std::size_t>(column)], csv_path));
                Series s = cumulative_series(
                    r <= static_cast<int>(labels.size()) ? labels[static_cast<std::size_t>(r - 1)] : "regressor" + std::to_string(r),
                    std::move(nmes), plot.x.max);
                s.dashed = r > 1;
                plot.series.push_back(std::move(s));
            }
            if (plot.series.empty()) throw core::file_error(csv_path.string(), "no regressor1 column");
            plots.push_back(inline_svg(line_plot_svg(plot)));
        } catch (const core::Error& e) {
            context.warn(e.what());
        }
    }
    page.figures(plots);
    context.report.sections_shown.emplace_back("landmarks");
}

// A thumbnail at most `side` px on its longer side (never enlarged).
cv::Mat thumbnail(const cv::Mat& image, int side) {
    const double scale = std::min(1.0, static_cast<double>(side) / std::max(image.cols, image.rows));
    if (scale >= 1.0) return image;
    cv::Mat small;
    cv::resize(image, small, cv::Size(), scale, scale, cv::INTER_AREA);
    return small;
}

cv::Mat read_image(const fs::path& path, int flags = cv::IMREAD_COLOR) {
    cv::Mat image = cv::imread(path.string(), flags);
    if (image.empty()) throw core::file_error(path.string(), "cannot read image");
    return image;
}

// The input photograph with its 68 landmarks (0-based pixels) as dots sized to the face.
cv::Mat landmarks_overlay(const cv::Mat& image, const json& landmarks, const fs::path& source) {
    if (!landmarks.is_array() || landmarks.size() != 68) throw core::file_error(source.string(), "'landmarks' is not a list of 68 points");
    cv::Mat overlay = image.clone();
    double min_x = 1e18, max_x = -1e18;
    for (const auto& p : landmarks) {
        min_x = std::min(min_x, p.at(0).get<double>());
        max_x = std::max(max_x, p.at(0).get<double>());
    }
    const int radius = std::max(1, static_cast<int>(std::lround((max_x - min_x) / 80)));
    for (const auto& p : landmarks)
        cv::circle(overlay, cv::Point(cvRound(p.at(0).get<double>() * 4), cvRound(p.at(1).get<double>() * 4)), radius * 4,
                   cv::Scalar(0, 230, 0), cv::FILLED, cv::LINE_AA, 2);
    return overlay;
}

// Strips of input | landmarks | isomap | frontal for the faces `facesynth frontalise` wrote into `dir`.
// Returns whether any strip was shown.
bool frontalised_strips(const fs::path& dir, Context& context) {
    HtmlPage& page = context.page;
    const auto frontals = files_matching(dir, "", ".frontal.png");
    constexpr std::size_t kMaxExamples = 12;
    constexpr int kSide = 260;  // twice the displayed size, for sharp thumbnails on dense screens
    std::size_t count = 0;
    page.subheading("Frontalised: " + dir.filename().string());
    page.raw("<div class=\"strips\">\n");
    for (const auto& frontal_path : frontals) {
        if (count == kMaxExamples) break;
        const std::string stem = name_between(frontal_path, "", ".frontal.png");
        const fs::path json_path = dir / (stem + ".json");
        try {
            json record;
            try {
                record = json::parse(core::read_file(json_path));
            } catch (const json::exception& e) {
                throw core::file_error(json_path.string(), std::string("invalid JSON: ") + e.what());
            }
            // The input's path as frontalise was given it; relative paths may be relative to another folder.
            fs::path input_path = record.at("image").get<std::string>();
            if (!fs::exists(input_path) && fs::exists(dir / input_path.filename())) input_path = dir / input_path.filename();
            const cv::Mat input = read_image(input_path);
            const cv::Mat overlay = landmarks_overlay(input, record.at("landmarks"), json_path);
            const cv::Mat isomap = read_image(dir / (stem + ".isomap.png"), cv::IMREAD_UNCHANGED);
            const cv::Mat frontal = read_image(frontal_path);
            std::string strip = "<div class=\"strip\">";
            strip += img_tag(thumbnail(input, kSide), ImageCoding::kJpeg, stem + " input");
            strip += img_tag(thumbnail(overlay, kSide), ImageCoding::kJpeg, stem + " landmarks");
            strip += img_tag(thumbnail(isomap, kSide), ImageCoding::kPng, stem + " isomap");
            strip += img_tag(thumbnail(frontal, kSide), ImageCoding::kJpeg, stem + " frontal");
            std::string caption = input_path.filename().string();
            if (record.contains("yaw_deg")) caption += ", fitted yaw " + fixed(number_at(record, "yaw_deg"), 1) + "°";
            if (record.contains("landmarks_source")) caption += ", landmarks: " + text_at(record, "landmarks_source");
            strip += "<div class=\"caption\">" + xml_escape(caption) + "</div></div>\n";
            page.raw(strip);
            ++count;
        } catch (const json::exception& e) {
            context.warn(json_path.string() + ": " + e.what());
        } catch (const core::Error& e) {
            context.warn(e.what());
        }
    }
    page.raw("</div>\n");
    if (frontals.size() > count) page.note(std::to_string(frontals.size() - count) + " more in " + dir.string());
    return count > 0;
}

void frontalise_section(const fs::path& evals, Context& context) {
    HtmlPage& page = context.page;
    page.section("frontalise", "Frontalisation");
    bool shown = false;
    // Every folder of the results with frontalise outputs (the quickstart writes frontalise/).
    std::vector<fs::path> folders;
    std::error_code error;
    if (!evals.empty())
        for (const auto& entry : fs::directory_iterator(evals, error))
            if (entry.is_directory() && !files_matching(entry.path(), "", ".frontal.png").empty()) folders.push_back(entry.path());
    std::sort(folders.begin(), folders.end());
    if (folders.empty()) {
        page.missing("frontalised faces (a folder of the results with <stem>.frontal.png, .isomap.png and .json files)",
                     "facesynth frontalise --landmarks pts FACE.png --out EVALS/frontalised");
    } else {
        page.paragraph("Each strip: the input, its 68 landmarks, the texture extracted into the model's uv layout (isomap; transparent "
                       "where the surface was hidden or seen edge-on), and the fitted face rendered frontally with that texture.");
        for (const auto& folder : folders) shown |= frontalised_strips(folder, context);
    }

    page.subheading("Ground-truth benchmark (synthetic)");
    const fs::path eval_path = evals.empty() ? fs::path() : evals / layout::kFrontaliseEval;
    if (eval_path.empty() || !fs::exists(eval_path)) {
        page.missing("the frontalisation benchmark (" + std::string(layout::kFrontaliseEval) + ")",
                     "facesynth eval frontalise --model builtin --json EVALS/" + std::string(layout::kFrontaliseEval));
    } else if (const auto j = load_json(eval_path, context)) {
        const auto bins = yaw_bins(*j);
        std::vector<std::string> metrics;
        for (const Bin& bin : bins)
            for (const auto& [metric, value] : bin.metrics)
                if (std::find(metrics.begin(), metrics.end(), metric) == metrics.end()) metrics.push_back(metric);
        std::vector<std::vector<std::string>> rows;
        for (const Bin& bin : bins) {
            std::vector<std::string> row{bin.label()};
            for (const auto& metric : metrics) row.push_back(fixed(bin.at(metric), 3));
            rows.push_back(std::move(row));
        }
        std::vector<std::string> header{"|yaw|"};
        header.insert(header.end(), metrics.begin(), metrics.end());
        if (rows.empty()) page.note(eval_path.string() + " has no per-yaw keys (yaw_<lo>_<hi>_<metric>)");
        else page.table(header, rows);
        shown = true;
    }
    (shown ? context.report.sections_shown : context.report.sections_missing).emplace_back("frontalise");
}

// Recognition keys: gallery<G>_yaw_<lo>_<hi>_<metric>, G = the gallery's yaw in degrees.
std::map<int, std::vector<Bin>> recognition_bins(const json& j) {
    std::map<int, std::vector<Bin>> galleries;
    for (const auto& [key, value] : j.items()) {
        std::string_view rest(key);
        if (!take(rest, "gallery")) continue;
        const auto gallery = take_int(rest);
        if (!gallery || *gallery < 0 || !rest.starts_with("_yaw_") || galleries.contains(*gallery)) continue;
        galleries[*gallery] = yaw_bins(j, "gallery" + std::to_string(*gallery) + "_");
    }
    return galleries;
}

void recognition_det_plots(const fs::path& csv_path, Context& context, std::vector<std::string>& plots) {
    const Csv csv = read_csv(csv_path);
    const int gallery_col = csv.column("gallery_deg"), low_col = csv.column("probe_yaw_low"), high_col = csv.column("probe_yaw_high"),
              method_col = csv.column("method"), far_col = csv.column("far"), frr_col = csv.column("frr");
    if (std::min({gallery_col, low_col, high_col, method_col, far_col, frr_col}) < 0)
        throw core::file_error(csv_path.string(), "needs the columns gallery_deg, probe_yaw_low, probe_yaw_high, method, far, frr");
    // gallery -> (probe bin, method) -> curve
    std::map<int, std::map<std::pair<std::pair<int, int>, std::string>, Series>> curves;
    for (const auto& row : csv.rows) {
        const auto at = [&](int c) { return row[static_cast<std::size_t>(c)]; };
        const int gallery = static_cast<int>(parse_number(at(gallery_col), csv_path));
        const std::pair<int, int> bin{static_cast<int>(parse_number(at(low_col), csv_path)), static_cast<int>(parse_number(at(high_col), csv_path))};
        Series& s = curves[gallery][{bin, at(method_col)}];
        s.x.push_back(parse_number(at(far_col), csv_path));
        s.y.push_back(parse_number(at(frr_col), csv_path));
    }
    for (auto& [gallery, by_curve] : curves) {
        // Three probe bins keep the plot readable: the gallery's own pose, a middle one and the largest.
        std::vector<std::pair<int, int>> bins;
        for (const auto& [key, series] : by_curve)
            if (bins.empty() || bins.back() != key.first) bins.push_back(key.first);
        std::vector<std::pair<int, int>> chosen;
        for (std::size_t pick : {std::size_t{0}, bins.size() / 2, bins.size() - 1})
            if (pick < bins.size() && std::find(chosen.begin(), chosen.end(), bins[pick]) == chosen.end()) chosen.push_back(bins[pick]);
        LinePlot plot;
        plot.title = "DET, gallery at " + std::to_string(gallery) + "° yaw";
        // Log axes from the decade of the smallest positive rate (at most down to 0.01 %).
        double far_min = 1, frr_min = 1;
        for (const auto& [key, series] : by_curve)
            for (std::size_t k = 0; k < series.x.size(); ++k) {
                if (series.x[k] > 0) far_min = std::min(far_min, series.x[k]);
                if (series.y[k] > 0) frr_min = std::min(frr_min, series.y[k]);
            }
        const auto decade_below = [](double v) { return std::max(1e-4, std::min(1e-2, std::pow(10.0, std::floor(std::log10(v) + 1e-9)))); };
        plot.x = share_axis("false accept rate", decade_below(far_min), 1, true);
        plot.y = share_axis("false reject rate", decade_below(frr_min), 1, true);
        for (std::size_t b = 0; b < chosen.size(); ++b)
            for (const auto& [key, series] : by_curve) {
                if (key.first != chosen[b]) continue;
                Series s = series;
                s.label = (key.second == "lm" ? std::string("LM") : key.second) + ", probes " + std::to_string(key.first.first) + "–" + std::to_string(key.first.second) + "°";
                s.colour = static_cast<int>(b);
                s.dashed = key.second == "org";
                plot.series.push_back(std::move(s));
            }
        plots.push_back(inline_svg(line_plot_svg(plot)));
    }
    (void)context;
}

void recognition_section(const fs::path& evals, Context& context) {
    HtmlPage& page = context.page;
    page.section("recognition", "Pose-invariant recognition");
    const fs::path eval_path = evals.empty() ? fs::path() : evals / layout::kRecognitionEval;
    if (eval_path.empty() || !fs::exists(eval_path)) {
        page.missing("the recognition experiment (" + std::string(layout::kRecognitionEval) + ")",
                     "facesynth eval recognition --model builtin --json EVALS/" + std::string(layout::kRecognitionEval) + " --det-csv EVALS/" +
                         layout::kRecognitionDet);
        context.report.sections_missing.emplace_back("recognition");
        return;
    }
    const auto j = load_json(eval_path, context);
    if (!j) {
        context.report.sections_missing.emplace_back("recognition");
        return;
    }
    page.paragraph("Verification on synthetic identities (" + text_at(*j, "identities") + " identities, matcher: " + text_at(*j, "matcher") +
                   ", landmarks: " + text_at(*j, "landmarks") + "). org: the face crop aligned by the eye centres; LM: the frontal "
                   "rendering from the fitted model and extracted texture. FRR at FAR = " + text_at(*j, "far") +
                   " per probe yaw bin; improvement = FRR(org) − FRR(LM), in percentage points.");
    std::vector<std::string> plots;
    const auto galleries = recognition_bins(*j);
    std::vector<std::string> header{"probe |yaw|"};
    std::map<std::pair<int, int>, std::vector<std::string>> rows_by_bin;  // (low, high) -> cells
    for (const auto& [gallery, bins] : galleries)
        for (const Bin& bin : bins) rows_by_bin[{bin.low, bin.high}] = {bin.label()};
    for (const auto& [gallery, bins] : galleries) {
        const std::string g = std::to_string(gallery) + "°: ";
        header.insert(header.end(), {g + "FRR org", g + "FRR LM", g + "improvement (points)"});
        BarChart chart;
        chart.title = "FRR at FAR = " + text_at(*j, "far") + ", gallery at " + std::to_string(gallery) + "°";
        chart.y_label = "false reject rate";
        chart.series_labels = {"org", "LM"};
        chart.percent = true;
        for (const Bin& bin : bins) {
            chart.groups.push_back({bin.label(), {bin.at("frr_org"), bin.at("frr_lm")}});
            auto& row = rows_by_bin[{bin.low, bin.high}];
            row.resize(header.size() - 3, "–");  // a bin this gallery's predecessors lacked
            row.insert(row.end(), {percent(bin.at("frr_org")), percent(bin.at("frr_lm")), fixed(100 * (bin.at("frr_org") - bin.at("frr_lm")), 1)});
        }
        plots.push_back(inline_svg(bar_chart_svg(chart)));
    }
    std::vector<std::vector<std::string>> rows;
    for (auto& [range, row] : rows_by_bin) {
        row.resize(header.size(), "–");
        rows.push_back(row);
    }
    page.table(header, rows);
    const fs::path det_path = evals / layout::kRecognitionDet;
    if (fs::exists(det_path)) {
        try {
            recognition_det_plots(det_path, context, plots);
        } catch (const core::Error& e) {
            context.warn(e.what());
        }
    } else {
        page.missing("DET curves (" + std::string(layout::kRecognitionDet) + ")",
                     "facesynth eval recognition … --det-csv EVALS/" + std::string(layout::kRecognitionDet));
    }
    page.figures(plots);
    const fs::path photos_path = evals / layout::kRecognitionPhotos;
    if (fs::exists(photos_path))
        if (const auto p = load_json(photos_path, context)) {
            page.subheading("Photographs of the same people (" + text_at(*p, "photos") + ")");
            page.table({"photos", "identities", "genuine pairs", "impostor pairs", "FRR org", "FRR LM", "AUC org", "AUC LM"},
                       {{text_at(*p, "photos_images"), text_at(*p, "photos_identities"), text_at(*p, "photos_genuine"), text_at(*p, "photos_impostor"),
                         percent(number_at(*p, "photos_frr_org")), percent(number_at(*p, "photos_frr_lm")), fixed(number_at(*p, "photos_auc_org"), 3),
                         fixed(number_at(*p, "photos_auc_lm"), 3)}});
        }
    context.report.sections_shown.emplace_back("recognition");
}

}  // namespace

Report build_report(const ReportInputs& inputs) {
    Report report;
    HtmlPage page(inputs.title);
    Context context{page, report};
    if (!inputs.evals.empty()) {
        std::error_code error;
        if (!fs::is_directory(inputs.evals, error)) throw core::file_error(inputs.evals.string(), "not a folder (--evals)");
    }
    page.raw("<p>Made by <code>facesynth report</code>" +
             (inputs.evals.empty() ? std::string(" without a results folder") : " from results in <code>" + xml_escape(inputs.evals.string()) + "</code>") +
             (inputs.dataset.empty() ? std::string() : " and dataset <code>" + xml_escape(inputs.dataset.string()) + "</code>") +
             ". Sections whose inputs were not found say so and name the command that makes them (docs/report.md).</p>\n");
    samples_section(inputs, context);
    fit_section(inputs.evals, context);
    landmarks_section(inputs.evals, context);
    frontalise_section(inputs.evals, context);
    recognition_section(inputs.evals, context);
    report.html = page.finish();
    return report;
}

}  // namespace facesynth::report
