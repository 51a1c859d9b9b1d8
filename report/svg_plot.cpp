#include "report/svg_plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

namespace facesynth::report {
namespace {

constexpr double kLeft = 64, kRight = 18, kTop = 34, kAxisBelow = 44, kLegendRow = 18;
constexpr double kCharWidth = 7;  // average width of a 12 px sans-serif character, for layout only

std::string number(double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.2f", v);
    return text;
}

std::string tick_label(double v, bool percent) {
    char text[32];
    if (std::abs(v) < 1e-12) v = 0;  // no "-0"
    if (percent) {
        const double p = 100 * v;
        std::snprintf(text, sizeof text, std::abs(p) < 1 && p != 0 ? "%.2g%%" : "%.0f%%", p);
    } else {
        std::snprintf(text, sizeof text, "%g", v);
    }
    return text;
}

// 1, 2 or 5 times a power of ten, giving about `target` intervals over [min, max].
std::vector<double> linear_ticks(double min, double max, int target = 6) {
    const double span = max - min;
    if (!(span > 0)) return {min};
    const double raw = span / target;
    const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
    double step = magnitude;
    for (double m : {1.0, 2.0, 5.0, 10.0})
        if (raw <= m * magnitude) {
            step = m * magnitude;
            break;
        }
    std::vector<double> ticks;
    for (double t = std::ceil(min / step - 1e-9) * step; t <= max + 1e-9 * span; t += step) ticks.push_back(t);
    return ticks;
}

std::vector<double> ticks_of(const Axis& axis) {
    if (!axis.ticks.empty()) return axis.ticks;
    if (!axis.log) return linear_ticks(axis.min, axis.max);
    std::vector<double> ticks;
    for (double e = std::ceil(std::log10(axis.min) - 1e-9); e <= std::log10(axis.max) + 1e-9; e += 1) ticks.push_back(std::pow(10.0, e));
    return ticks;
}

// Position in [0, 1] along the axis (outside for values outside the range).
double fraction(const Axis& axis, double v) {
    if (axis.log) return (std::log10(v) - std::log10(axis.min)) / (std::log10(axis.max) - std::log10(axis.min));
    return (v - axis.min) / (axis.max - axis.min);
}

bool inside(const Axis& axis, double v) {
    const double f = fraction(axis, v);
    return f >= -1e-9 && f <= 1 + 1e-9;
}

struct Legend {
    std::string svg;
    double height = 0;
};

// Series labels in rows under the plot, wrapped to the width.
Legend legend(const std::vector<std::string>& labels, const std::vector<bool>& dashed, const std::vector<int>& colours, double width,
              double top) {
    Legend out;
    double x = kLeft, row = 0;
    for (std::size_t i = 0; i < labels.size(); ++i) {
        const double item = 30 + kCharWidth * static_cast<double>(labels[i].size()) + 18;
        if (x + item > width - kRight && x > kLeft) {
            x = kLeft;
            row += 1;
        }
        const double y = top + kLegendRow * row + 12;
        out.svg += "<line x1=\"" + number(x) + "\" y1=\"" + number(y - 4) + "\" x2=\"" + number(x + 24) + "\" y2=\"" + number(y - 4) +
                   "\" stroke=\"" +
                   std::string(series_colour(i < colours.size() && colours[i] >= 0 ? static_cast<std::size_t>(colours[i]) : i)) +
                   "\" stroke-width=\"2.5\"" +
                   (i < dashed.size() && dashed[i] ? " stroke-dasharray=\"6 4\"" : "") + "/>";
        out.svg += "<text x=\"" + number(x + 30) + "\" y=\"" + number(y) + "\">" + xml_escape(labels[i]) + "</text>\n";
        x += item;
    }
    out.height = labels.empty() ? 0 : kLegendRow * (row + 1) + 6;
    return out;
}

std::string header(double width, double height, const std::string& title) {
    std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + number(width) + "\" height=\"" + number(height) +
                      "\" viewBox=\"0 0 " + number(width) + " " + number(height) +
                      "\" font-family=\"sans-serif\" font-size=\"12\" fill=\"#222\">\n"
                      "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    if (!title.empty())
        svg += "<text x=\"" + number(width / 2) + "\" y=\"20\" text-anchor=\"middle\" font-size=\"14\" font-weight=\"bold\">" +
               xml_escape(title) + "</text>\n";
    return svg;
}

std::string axis_titles(const std::string& x_label, const std::string& y_label, double plot_left, double plot_right, double plot_top,
                        double plot_bottom) {
    const double mid_y = (plot_top + plot_bottom) / 2;
    return "<text x=\"" + number((plot_left + plot_right) / 2) + "\" y=\"" + number(plot_bottom + 36) + "\" text-anchor=\"middle\">" +
           xml_escape(x_label) + "</text>\n<text x=\"14\" y=\"" + number(mid_y) + "\" text-anchor=\"middle\" transform=\"rotate(-90 14 " +
           number(mid_y) + ")\">" + xml_escape(y_label) + "</text>\n";
}

}  // namespace

std::string_view series_colour(std::size_t i) {
    static constexpr std::array<std::string_view, 8> kColours = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                                                 "#9467bd", "#8c564b", "#e377c2", "#17becf"};
    return kColours[i % kColours.size()];
}

Series cumulative_series(std::string label, std::vector<double> values, double x_max) {
    for (double& v : values)
        if (std::isnan(v)) v = std::numeric_limits<double>::infinity();
    std::sort(values.begin(), values.end());
    Series series;
    series.label = std::move(label);
    series.steps = true;
    series.x.push_back(0);
    series.y.push_back(0);
    const double n = static_cast<double>(std::max<std::size_t>(values.size(), 1));
    for (std::size_t i = 0; i < values.size() && values[i] <= x_max; ++i) {
        series.x.push_back(values[i]);
        series.y.push_back(static_cast<double>(i + 1) / n);
    }
    series.x.push_back(x_max);
    series.y.push_back(series.y.back());
    return series;
}

LinePlot ced_plot(std::string title, double max_nme) {
    LinePlot plot;
    plot.title = std::move(title);
    plot.x = linear_axis("NME (inter-ocular)", 0, max_nme, linear_ticks(0, max_nme, 8));
    plot.y = share_axis("share of faces");
    return plot;
}

std::string xml_escape(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (char c : text) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            case '\'': out += "&#39;"; break;
            default: out += c;
        }
    }
    return out;
}

std::string line_plot_svg(const LinePlot& plot) {
    const double width = plot.width, plot_height = plot.height;
    std::vector<std::string> labels;
    std::vector<bool> dashed;
    std::vector<int> colours;
    for (const auto& s : plot.series) {
        labels.push_back(s.label);
        dashed.push_back(s.dashed);
        colours.push_back(s.colour);
    }
    const double left = kLeft, right = width - kRight, top = kTop, bottom = plot_height - kAxisBelow;
    const Legend key = legend(labels, dashed, colours, width, plot_height);
    const double height = plot_height + key.height;
    // Points outside the ranges are pulled onto the frame, so that curves stop at its edge.
    const auto px = [&](double x) { return left + (right - left) * std::clamp(fraction(plot.x, x), 0.0, 1.0); };
    const auto py = [&](double y) { return bottom - (bottom - top) * std::clamp(fraction(plot.y, y), 0.0, 1.0); };

    std::string svg = header(width, height, plot.title);
    for (double t : ticks_of(plot.x)) {
        if (!inside(plot.x, t)) continue;
        const double x = px(t);
        svg += "<line x1=\"" + number(x) + "\" y1=\"" + number(top) + "\" x2=\"" + number(x) + "\" y2=\"" + number(bottom) +
               "\" stroke=\"#e4e4e4\"/><text x=\"" + number(x) + "\" y=\"" + number(bottom + 16) + "\" text-anchor=\"middle\">" +
               tick_label(t, plot.x.percent) + "</text>\n";
    }
    for (double t : ticks_of(plot.y)) {
        if (!inside(plot.y, t)) continue;
        const double y = py(t);
        svg += "<line x1=\"" + number(left) + "\" y1=\"" + number(y) + "\" x2=\"" + number(right) + "\" y2=\"" + number(y) +
               "\" stroke=\"#e4e4e4\"/><text x=\"" + number(left - 6) + "\" y=\"" + number(y + 4) + "\" text-anchor=\"end\">" +
               tick_label(t, plot.y.percent) + "</text>\n";
    }
    svg += "<rect x=\"" + number(left) + "\" y=\"" + number(top) + "\" width=\"" + number(right - left) + "\" height=\"" +
           number(bottom - top) + "\" fill=\"none\" stroke=\"#888\"/>\n";
    svg += axis_titles(plot.x.label, plot.y.label, left, right, top, bottom);

    for (std::size_t i = 0; i < plot.series.size(); ++i) {
        const Series& s = plot.series[i];
        const std::string colour(series_colour(s.colour >= 0 ? static_cast<std::size_t>(s.colour) : i));
        std::vector<std::string> runs(1);
        std::string dots;
        double previous_y = NAN;
        const std::size_t n = std::min(s.x.size(), s.y.size());
        for (std::size_t k = 0; k < n; ++k) {
            const bool usable = std::isfinite(s.x[k]) && std::isfinite(s.y[k]) && (!plot.x.log || s.x[k] > 0) && (!plot.y.log || s.y[k] > 0);
            if (!usable) {
                if (!runs.back().empty()) runs.emplace_back();
                previous_y = NAN;
                continue;
            }
            if (s.steps && std::isfinite(previous_y)) runs.back() += number(px(s.x[k])) + "," + number(py(previous_y)) + " ";
            runs.back() += number(px(s.x[k])) + "," + number(py(s.y[k])) + " ";
            previous_y = s.y[k];
            if (s.markers) dots += "<circle cx=\"" + number(px(s.x[k])) + "\" cy=\"" + number(py(s.y[k])) + "\" r=\"3\" fill=\"" + colour + "\"/>";
        }
        for (const auto& run : runs)
            if (!run.empty())
                svg += "<polyline fill=\"none\" stroke=\"" + colour + "\" stroke-width=\"2\"" + (s.dashed ? " stroke-dasharray=\"6 4\"" : "") +
                       " points=\"" + run + "\"/>\n";
        svg += dots;
    }
    svg += key.svg + "</svg>\n";
    return svg;
}

std::string bar_chart_svg(const BarChart& chart) {
    const double width = chart.width, plot_height = chart.height;
    const double left = kLeft, right = width - kRight, top = kTop, bottom = plot_height - kAxisBelow;
    const Legend key = legend(chart.series_labels, {}, {}, width, plot_height);
    const double height = plot_height + key.height;
    Axis y_axis = linear_axis(chart.y_label, chart.y_min, chart.y_max);
    y_axis.percent = chart.percent;
    const auto py = [&](double y) { return bottom - (bottom - top) * std::clamp(fraction(y_axis, y), 0.0, 1.0); };

    std::string svg = header(width, height, chart.title);
    for (double t : ticks_of(y_axis))
        svg += "<line x1=\"" + number(left) + "\" y1=\"" + number(py(t)) + "\" x2=\"" + number(right) + "\" y2=\"" + number(py(t)) +
               "\" stroke=\"" + (std::abs(t) < 1e-12 ? "#888" : "#e4e4e4") + "\"/><text x=\"" + number(left - 6) + "\" y=\"" +
               number(py(t) + 4) + "\" text-anchor=\"end\">" + tick_label(t, chart.percent) + "</text>\n";
    svg += "<rect x=\"" + number(left) + "\" y=\"" + number(top) + "\" width=\"" + number(right - left) + "\" height=\"" +
           number(bottom - top) + "\" fill=\"none\" stroke=\"#888\"/>\n";
    svg += axis_titles("", chart.y_label, left, right, top, bottom);
    const double group_width = (right - left) / static_cast<double>(std::max<std::size_t>(chart.groups.size(), 1));
    const std::size_t per_group = std::max<std::size_t>(chart.series_labels.size(), 1);
    const double bar_width = 0.8 * group_width / static_cast<double>(per_group);
    const double zero = py(std::clamp(0.0, chart.y_min, chart.y_max));
    for (std::size_t g = 0; g < chart.groups.size(); ++g) {
        const double x0 = left + group_width * static_cast<double>(g) + 0.1 * group_width;
        svg += "<text x=\"" + number(left + group_width * (static_cast<double>(g) + 0.5)) + "\" y=\"" + number(bottom + 16) +
               "\" text-anchor=\"middle\">" + xml_escape(chart.groups[g].label) + "</text>\n";
        for (std::size_t s = 0; s < chart.groups[g].values.size() && s < per_group; ++s) {
            const double v = chart.groups[g].values[s];
            if (!std::isfinite(v)) continue;
            const double y = py(v);
            svg += "<rect x=\"" + number(x0 + bar_width * static_cast<double>(s)) + "\" y=\"" + number(std::min(y, zero)) + "\" width=\"" +
                   number(bar_width * 0.92) + "\" height=\"" + number(std::max(std::abs(zero - y), 0.5)) + "\" fill=\"" +
                   std::string(series_colour(s)) + "\"><title>" + xml_escape(chart.series_labels.size() > s ? chart.series_labels[s] : "") +
                   " " + xml_escape(chart.groups[g].label) + ": " + tick_label(v, chart.percent) + "</title></rect>\n";
        }
    }
    svg += key.svg + "</svg>\n";
    return svg;
}

}  // namespace facesynth::report
