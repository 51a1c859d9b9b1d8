// The report's building blocks: base64, escaping, and the SVG plots' structure (one polyline per
// series, log axes skipping non-positive values, one rect per bar).
#include "common/test_data.h"
#include "core/error.h"
#include "report/html.h"
#include "report/svg_plot.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <limits>
#include <vector>
#include <string>

namespace {

using namespace facesynth::report;
using facesynth::testkit::count_occurrences;

TEST(Report, Base64MatchesRfc4648Vectors) {
    EXPECT_EQ(base64(""), "");
    EXPECT_EQ(base64("f"), "Zg==");
    EXPECT_EQ(base64("fo"), "Zm8=");
    EXPECT_EQ(base64("foo"), "Zm9v");
    EXPECT_EQ(base64("foob"), "Zm9vYg==");
    EXPECT_EQ(base64("fooba"), "Zm9vYmE=");
    EXPECT_EQ(base64("foobar"), "Zm9vYmFy");
    EXPECT_EQ(base64(std::string("\xff\x00\x80", 3)), "/wCA");
}

TEST(Report, EscapesMarkup) {
    EXPECT_EQ(xml_escape("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
}

TEST(Report, LinePlotHasOnePolylinePerSeriesAndEscapedLabels) {
    LinePlot plot;
    plot.title = "errors <by> yaw";
    plot.x = linear_axis("x", 0, 10);
    plot.y = linear_axis("y", 0, 1);
    Series a;
    a.label = "ours & theirs";
    a.x = {0, 5, 10};
    a.y = {0.1, 0.5, 0.9};
    Series b = a;
    b.label = "baseline";
    b.dashed = true;
    b.y = {0.2, NAN, 0.3};  // a gap: two runs of one point each
    plot.series = {a, b};
    const std::string svg = line_plot_svg(plot);
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_NE(svg.find("</svg>"), std::string::npos);
    EXPECT_NE(svg.find("viewBox"), std::string::npos);
    EXPECT_NE(svg.find("ours &amp; theirs"), std::string::npos);
    EXPECT_NE(svg.find("errors &lt;by&gt; yaw"), std::string::npos);
    EXPECT_EQ(svg.find("<by>"), std::string::npos);
    EXPECT_EQ(count_occurrences(svg, "<polyline"), 3u);
    EXPECT_EQ(count_occurrences(svg, "stroke-dasharray"), 2u + 1u);  // b's two runs and its legend line
    EXPECT_EQ(svg.find("nan"), std::string::npos);
}

TEST(Report, CumulativeSeriesIsAStaircaseCountingMissesInTheTotal) {
    const double inf = std::numeric_limits<double>::infinity();
    const Series s = cumulative_series("ours", {0.05, 0.01, inf, std::nan(""), 0.2}, 0.08);
    EXPECT_TRUE(s.steps);
    ASSERT_EQ(s.x, (std::vector<double>{0, 0.01, 0.05, 0.08}));
    ASSERT_EQ(s.y, (std::vector<double>{0, 0.2, 0.4, 0.4}));
    const LinePlot plot = ced_plot("CED");
    EXPECT_DOUBLE_EQ(plot.x.max, 0.08);
    EXPECT_TRUE(plot.y.percent);
}

TEST(Report, LogAxisDropsNonPositivePointsAndLabelsDecades) {
    LinePlot plot;
    plot.x = share_axis("FAR", 1e-3, 1, true);
    plot.y = share_axis("FRR", 1e-3, 1, true);
    Series s;
    s.label = "det";
    s.x = {1e-3, 1e-2, 1e-1, 1};
    s.y = {0.5, 0.2, 0, 0.01};  // FRR 0 cannot be drawn on a log axis
    plot.series = {s};
    const std::string svg = line_plot_svg(plot);
    EXPECT_EQ(count_occurrences(svg, "<polyline"), 2u);
    for (const char* tick : {">0.1%<", ">1%<", ">10%<", ">100%<"}) EXPECT_NE(svg.find(tick), std::string::npos) << tick;
    EXPECT_EQ(svg.find("inf"), std::string::npos);
}

TEST(Report, BarChartHasOneRectPerFiniteValue) {
    BarChart chart;
    chart.series_labels = {"org", "LM"};
    chart.groups = {{"0-10", {0.1, 0.05}}, {"10-20", {0.3, NAN}}};
    chart.y_min = -0.1;
    chart.y_max = 0.5;
    chart.percent = true;
    const std::string svg = bar_chart_svg(chart);
    EXPECT_EQ(count_occurrences(svg, "<rect"), 2u /* background, frame */ + 3u);
    EXPECT_NE(svg.find(">0%<"), std::string::npos);
    EXPECT_EQ(svg.find("-0%"), std::string::npos);
}

TEST(Report, ImagesAreEmbeddedAsDataUris) {
    const cv::Mat image(8, 8, CV_8UC3, cv::Scalar(10, 20, 30));
    const std::string png = img_tag(image, ImageCoding::kPng, "a \"tile\"");
    EXPECT_EQ(png.rfind("<img alt=\"a &quot;tile&quot;\" src=\"data:image/png;base64,iVBORw0KGgo", 0), 0u) << png.substr(0, 80);
    const cv::Mat rgba(8, 8, CV_8UC4, cv::Scalar(10, 20, 30, 128));
    EXPECT_NE(img_tag(rgba, ImageCoding::kJpeg, "x").find("data:image/jpeg;base64,/9j/"), std::string::npos);
    EXPECT_THROW((void)img_tag(cv::Mat(), ImageCoding::kPng, "empty"), facesynth::core::Error);
}

TEST(Report, PageListsSectionsAndEscapesText) {
    HtmlPage page("t & t");
    page.section("one", "First <section>");
    page.paragraph("x < y");
    page.missing("the thing", "facesynth make --it");
    page.table({"a", "b"}, {{"1", "2"}});
    const std::string html = page.finish();
    EXPECT_NE(html.find("<title>t &amp; t</title>"), std::string::npos);
    EXPECT_NE(html.find("href=\"#one\""), std::string::npos);
    EXPECT_NE(html.find("First &lt;section&gt;"), std::string::npos);
    EXPECT_NE(html.find("<p>x &lt; y</p>"), std::string::npos);
    EXPECT_NE(html.find("facesynth make --it"), std::string::npos);
    EXPECT_EQ(count_occurrences(html, "<section"), count_occurrences(html, "</section>"));
}

}  // namespace
