#include "report/html.h"

#include "core/error.h"
#include "report/svg_plot.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <array>

namespace facesynth::report {

std::string base64(std::string_view bytes) {
    static constexpr std::string_view kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3) {
        const unsigned v = static_cast<unsigned char>(bytes[i]) << 16 | static_cast<unsigned char>(bytes[i + 1]) << 8 |
                           static_cast<unsigned char>(bytes[i + 2]);
        for (int shift : {18, 12, 6, 0}) out += kAlphabet[(v >> shift) & 63];
    }
    if (const std::size_t rest = bytes.size() - i; rest > 0) {
        unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
        if (rest == 2) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
        out += kAlphabet[(v >> 18) & 63];
        out += kAlphabet[(v >> 12) & 63];
        out += rest == 2 ? kAlphabet[(v >> 6) & 63] : '=';
        out += '=';
    }
    return out;
}

std::string img_tag(const cv::Mat& image, ImageCoding coding, std::string_view alt, int display_width) {
    std::vector<uchar> bytes;
    const bool png = coding == ImageCoding::kPng;
    const std::vector<int> params = png ? std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, 6} : std::vector<int>{cv::IMWRITE_JPEG_QUALITY, 85};
    cv::Mat encodable = image;
    if (!png && image.channels() == 4) cv::cvtColor(image, encodable, cv::COLOR_BGRA2BGR);
    if (image.empty() || !cv::imencode(png ? ".png" : ".jpg", encodable, bytes, params))
        throw core::Error("report: cannot encode image '" + std::string(alt) + "'");
    std::string tag = "<img alt=\"" + xml_escape(alt) + "\" src=\"data:image/" + (png ? "png" : "jpeg") + ";base64," +
                      base64(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size())) + "\"";
    if (display_width > 0) tag += " width=\"" + std::to_string(display_width) + "\"";
    return tag + ">";
}

HtmlPage::HtmlPage(std::string title) : title_(std::move(title)) {}

void HtmlPage::section(std::string_view id, std::string_view heading) {
    if (!contents_.empty()) body_ += "</section>\n";
    contents_.emplace_back(std::string(id), std::string(heading));
    body_ += "<section id=\"" + xml_escape(id) + "\">\n<h2>" + std::to_string(contents_.size()) + ". " + xml_escape(heading) + "</h2>\n";
}

void HtmlPage::subheading(std::string_view text) { body_ += "<h3>" + xml_escape(text) + "</h3>\n"; }

void HtmlPage::paragraph(std::string_view text) { body_ += "<p>" + xml_escape(text) + "</p>\n"; }

void HtmlPage::note(std::string_view text) { body_ += "<p class=\"note\">" + xml_escape(text) + "</p>\n"; }

void HtmlPage::missing(std::string_view what, std::string_view command) {
    body_ += "<div class=\"missing\"><b>Missing:</b> " + xml_escape(what);
    if (!command.empty()) body_ += "<br>Make it with: <code>" + xml_escape(command) + "</code>";
    body_ += "</div>\n";
}

void HtmlPage::table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
    body_ += "<div class=\"scroll\"><table>\n<tr>";
    for (const auto& h : header) body_ += "<th>" + xml_escape(h) + "</th>";
    body_ += "</tr>\n";
    for (const auto& row : rows) {
        body_ += "<tr>";
        for (std::size_t c = 0; c < row.size(); ++c) body_ += (c == 0 ? "<td class=\"label\">" : "<td>") + xml_escape(row[c]) + "</td>";
        body_ += "</tr>\n";
    }
    body_ += "</table></div>\n";
}

void HtmlPage::figures(const std::vector<std::string>& items) {
    body_ += "<div class=\"figures\">\n";
    for (const auto& item : items) body_ += "<figure>" + item + "</figure>\n";
    body_ += "</div>\n";
}

void HtmlPage::raw(std::string_view html) { body_ += html; }

std::string HtmlPage::finish() const {
    static constexpr std::string_view kStyle = R"(
body { font-family: -apple-system, "Segoe UI", "DejaVu Sans", Arial, sans-serif; color: #222; background: #fafafa;
       max-width: 1180px; margin: 0 auto; padding: 16px 24px 48px; line-height: 1.45; }
h1 { font-size: 26px; margin: 8px 0 4px; }
h2 { font-size: 20px; margin-top: 36px; padding-bottom: 4px; border-bottom: 2px solid #1f77b4; }
h3 { font-size: 16px; margin: 22px 0 8px; }
nav ol { columns: 2; background: #fff; border: 1px solid #ddd; padding: 10px 10px 10px 36px; border-radius: 6px; }
a { color: #1f5f9f; }
code { background: #eef1f4; padding: 1px 4px; border-radius: 3px; font-size: 13px; word-break: break-all; }
.note { background: #fff8e1; border-left: 4px solid #f0b400; padding: 6px 10px; }
.missing { background: #f1f1f1; border-left: 4px solid #999; padding: 8px 12px; margin: 8px 0; color: #444; }
.scroll { overflow-x: auto; }
table { border-collapse: collapse; background: #fff; margin: 8px 0 12px; font-size: 13px; }
th, td { border: 1px solid #ddd; padding: 4px 8px; text-align: right; white-space: nowrap; }
th { background: #eef3f8; text-align: center; white-space: normal; vertical-align: bottom; }
td.label { text-align: left; }
.figures { display: flex; flex-wrap: wrap; gap: 12px; align-items: flex-start; }
figure { margin: 0; background: #fff; border: 1px solid #ddd; padding: 4px; max-width: 100%; }
figure svg, figure img { display: block; max-width: 100%; height: auto; }
figcaption { font-size: 12px; color: #555; text-align: center; padding-top: 2px; }
.strips { display: flex; flex-wrap: wrap; gap: 10px; }
.strip { display: grid; grid-template-columns: repeat(4, 136px); gap: 4px; background: #fff; border: 1px solid #ddd; padding: 5px; }
.strip img { width: 100%; height: auto; display: block; background: repeating-conic-gradient(#ddd 0% 25%, #fff 0% 50%) 0 0 / 16px 16px; }
.strip .caption { grid-column: 1 / -1; font-size: 12px; color: #555; }
.sheet img { max-width: 100%; height: auto; }
)";
    std::string page = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" + xml_escape(title_) +
                       "</title>\n<style>" + std::string(kStyle) + "</style>\n</head>\n<body>\n<h1>" + xml_escape(title_) + "</h1>\n";
    if (!contents_.empty()) {
        page += "<nav><ol>\n";
        for (const auto& [id, heading] : contents_) page += "<li><a href=\"#" + xml_escape(id) + "\">" + xml_escape(heading) + "</a></li>\n";
        page += "</ol></nav>\n";
    }
    page += body_;
    if (!contents_.empty()) page += "</section>\n";
    return page + "</body>\n</html>\n";
}

}  // namespace facesynth::report
