#pragma once
// The project's SVG plots (line plots with linear or log axes, grouped bar charts), written as
// self-contained SVG text for reports and `--*.svg` outputs. One style everywhere: white background,
// light grid, sans-serif labels, the same colour for the same series position.
#include <string>
#include <string_view>
#include <vector>

namespace facesynth::report {

struct Axis {
    std::string label;
    double min = 0;
    double max = 1;
    bool log = false;            // log10 scale; min must then be > 0
    std::vector<double> ticks;   // empty: about 6 evenly spaced ticks (decades on a log axis)
    bool percent = false;        // tick labels as percentages of 1
};

// Shorthand for the common cases.
[[nodiscard]] inline Axis linear_axis(std::string label, double min, double max, std::vector<double> ticks = {}) {
    Axis axis;
    axis.label = std::move(label);
    axis.min = min;
    axis.max = max;
    axis.ticks = std::move(ticks);
    return axis;
}
[[nodiscard]] inline Axis share_axis(std::string label, double min = 0, double max = 1, bool log = false) {
    Axis axis = linear_axis(std::move(label), min, max);
    axis.log = log;
    axis.percent = true;
    return axis;
}

struct Series {
    std::string label;
    std::vector<double> x;
    std::vector<double> y;
    bool dashed = false;
    bool markers = false;        // a dot at every point
    bool steps = false;          // a staircase (for cumulative distributions)
    int colour = -1;             // index into series_colour(); -1: the series' position
};

// The cumulative distribution of `values` on [0, x_max] as a staircase series (a CED curve): the
// share of all values (non-finite ones included, as failures) that are <= x.
[[nodiscard]] Series cumulative_series(std::string label, std::vector<double> values, double x_max);

struct LinePlot {
    std::string title;
    Axis x;
    Axis y;
    std::vector<Series> series;
    int width = 560;
    int height = 380;
};

// An empty CED plot: landmark error (NME, inter-ocular) on [0, max_nme] against the share of faces;
// add one cumulative_series per method.
[[nodiscard]] LinePlot ced_plot(std::string title, double max_nme = 0.08);

// Points outside the axis ranges are drawn on the frame; non-finite points (and points <= 0 on a log
// axis) break the line.
[[nodiscard]] std::string line_plot_svg(const LinePlot& plot);

struct BarGroup {
    std::string label;           // under the group, e.g. "30-40°"
    std::vector<double> values;  // one per BarChart::series_labels entry; NaN: no bar
};

struct BarChart {
    std::string title;
    std::string y_label;
    std::vector<std::string> series_labels;
    std::vector<BarGroup> groups;
    double y_min = 0;            // may be negative (improvements): bars grow from 0
    double y_max = 1;
    bool percent = false;
    int width = 560;
    int height = 340;
};

[[nodiscard]] std::string bar_chart_svg(const BarChart& chart);

// The colour of the i-th series, shared by every plot.
[[nodiscard]] std::string_view series_colour(std::size_t i);

// Escapes &, <, >, " and ' for XML/HTML text and attribute values.
[[nodiscard]] std::string xml_escape(std::string_view text);

}  // namespace facesynth::report
