#pragma once
// A self-contained HTML page: inline CSS, images as data: URIs, SVG inline; no scripts and no
// outside resources, so that the file can be mailed or archived alone.
#include <opencv2/core.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace facesynth::report {

[[nodiscard]] std::string base64(std::string_view bytes);

// An <img> holding `image` (8-bit BGR, BGRA or grey) encoded as PNG (lossless: plots, isomaps with
// alpha) or JPEG (photographs, contact sheets); throws core::Error when encoding fails.
enum class ImageCoding { kPng, kJpeg };
[[nodiscard]] std::string img_tag(const cv::Mat& image, ImageCoding coding, std::string_view alt, int display_width = 0);

class HtmlPage {
public:
    explicit HtmlPage(std::string title);

    void section(std::string_view id, std::string_view heading);  // starts a numbered <h2> section
    void subheading(std::string_view text);
    void paragraph(std::string_view text);                         // escaped text
    void note(std::string_view text);                              // a highlighted remark (escaped)
    // "Missing: what. Make it with: command" in a grey box.
    void missing(std::string_view what, std::string_view command);
    void table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);
    void figures(const std::vector<std::string>& items);           // SVG or <img> HTML side by side, wrapping
    void raw(std::string_view html);                               // trusted HTML (our own SVG, <img>)

    // The complete document with a table of contents of the sections.
    [[nodiscard]] std::string finish() const;

private:
    std::string title_;
    std::vector<std::pair<std::string, std::string>> contents_;  // id, heading
    std::string body_;
};

}  // namespace facesynth::report
