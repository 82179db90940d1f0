// scan_vtk_xml, vtk_doubles, vtk_integers (vtk_xml_data.h). No VTK in the stack, so the XML is
// scanned here (only the elements VTK writes: no entities, no CDATA) and the binary data decoded
// with zlib. Base64 is decoded by hand: VTK pads the header and the compressed blocks as separate
// streams ("AQAAAACAAADwAAAAEQAAAA==eJxj..."), which a single-stream decoder stops at.
#include "vtk_xml_data.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#include "lamina/core/error.h"

namespace lamina::io::detail {
namespace {

using Attributes = std::map<std::string, std::string>;

bool is_space(char c) {
  return c == ' ' || c == '\n' || c == '\r' || c == '\t';
}

// name="value" pairs of one start tag (VTK writes no escapes in the attributes read here).
Attributes attributes_of(std::string_view tag) {
  Attributes out;
  size_t at = 0;
  while ((at = tag.find('=', at)) != std::string_view::npos) {
    size_t key_end = at;
    while (key_end > 0 && is_space(tag[key_end - 1])) --key_end;
    size_t key_begin = key_end;
    while (key_begin > 0 && !is_space(tag[key_begin - 1])) --key_begin;
    const size_t open = tag.find_first_of("\"'", at);
    if (open == std::string_view::npos) break;
    const size_t close = tag.find(tag[open], open + 1);
    if (close == std::string_view::npos) break;
    out[std::string(tag.substr(key_begin, key_end - key_begin))] =
        std::string(tag.substr(open + 1, close - open - 1));
    at = close + 1;
  }
  return out;
}

std::string get(const Attributes& a, const std::string& key) {
  const auto it = a.find(key);
  return it == a.end() ? std::string() : it->second;
}

// The frame's remaining fields from <VTKFile>'s attributes.
void read_layout(const std::string& path, const Attributes& a, VtkXmlFrame& f) {
  const std::string order = get(a, "byte_order");
  if (order == "BigEndian") {
    f.big_endian = true;
  } else if (!order.empty() && order != "LittleEndian") {
    throw invalid_input(path, "byte_order '" + order + "' is neither LittleEndian nor BigEndian");
  }
  const std::string header = get(a, "header_type");
  if (header == "UInt64") {
    f.header_bytes = 8;
  } else if (!header.empty() && header != "UInt32") {
    throw invalid_input(path, "header_type '" + header + "' is neither UInt32 nor UInt64");
  }
  const std::string compressor = get(a, "compressor");
  if (compressor == "vtkZLibDataCompressor") {
    f.zlib = true;
  } else if (!compressor.empty()) {
    throw invalid_input(path, "its data is compressed with " + compressor +
                                  ", which is not read here: save it with zlib or uncompressed");
  }
}

// --- Bytes of one array ---

std::string base64_bytes(const std::string& path, std::string_view text, const std::string& what) {
  static const auto table = [] {
    std::array<int8_t, 256> t{};
    t.fill(-1);
    const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (int i = 0; i < 64; ++i) t[static_cast<unsigned char>(digits[i])] = static_cast<int8_t>(i);
    return t;
  }();
  std::string out;
  out.reserve(text.size() / 4 * 3);
  uint32_t quad = 0;
  int have = 0;
  auto flush = [&] {  // a group ended by padding: 2 digits give 1 byte, 3 give 2
    if (have == 1) throw invalid_input(path, what + ": the base64 data is malformed");
    if (have >= 2) out.push_back(static_cast<char>(quad >> (6 * have - 8)));
    if (have == 3) out.push_back(static_cast<char>(quad >> (6 * have - 16)));
    quad = 0;
    have = 0;
  };
  for (const char c : text) {
    if (is_space(c)) continue;
    if (c == '=') {
      flush();
      continue;
    }
    const int v = table[static_cast<unsigned char>(c)];
    if (v < 0)
      throw invalid_input(path, what + ": the base64 data holds '" + std::string(1, c) + "'");
    quad = (quad << 6) | static_cast<uint32_t>(v);
    if (++have == 4) {
      out.push_back(static_cast<char>(quad >> 16));
      out.push_back(static_cast<char>(quad >> 8));
      out.push_back(static_cast<char>(quad));
      quad = 0;
      have = 0;
    }
  }
  if (have != 0) throw invalid_input(path, what + ": the base64 data is cut off");
  return out;
}

// Reads the header integers of a binary array one at a time from `bytes`.
struct HeaderReader {
  const VtkXmlFrame& f;
  std::string_view bytes;
  size_t at = 0;
  const std::string& what;

  uint64_t next() {
    if (bytes.size() - at < static_cast<size_t>(f.header_bytes))
      throw invalid_input(f.path, what + ": its data is cut off (in the header)");
    uint64_t v = 0;
    for (int k = 0; k < f.header_bytes; ++k) {
      const int shift = 8 * (f.big_endian ? f.header_bytes - 1 - k : k);
      v |= uint64_t{static_cast<unsigned char>(bytes[at + k])} << shift;
    }
    at += static_cast<size_t>(f.header_bytes);
    return v;
  }
};

// The array's data bytes (uncompressed), `expected` of them, from its header and blocks.
std::string data_bytes(const VtkXmlFrame& f, std::string_view bytes, size_t expected, bool any,
                       size_t element, const std::string& what) {
  HeaderReader h{f, bytes, 0, what};
  const uint64_t bound = expected;
  auto wrong_size = [&](uint64_t got) {
    return invalid_input(f.path, what + ": its data holds " + std::to_string(got) + " bytes" +
                                     (any ? " (not whole values, or too many)"
                                          : " where the piece needs " + std::to_string(expected)));
  };
  // Any count: whatever the header says, in whole values, within the caller's bound (expected
  // is then the bound in bytes, with the element size in `element`).
  auto fits = [&](uint64_t got) {
    return any ? got % element == 0 && got <= bound : got == expected;
  };
  if (!f.zlib) {
    const uint64_t n = h.next();
    if (!fits(n)) throw wrong_size(n);
    if (bytes.size() - h.at < n) throw invalid_input(f.path, what + ": its data is cut off");
    return std::string(bytes.substr(h.at, n));
  }
  // zlib: block count, block size, last block's size (0: a whole block), compressed sizes.
  const uint64_t blocks = h.next(), block_size = h.next(), last_size = h.next();
  if (blocks > bytes.size() / static_cast<size_t>(f.header_bytes))
    throw invalid_input(
        f.path, what + ": its compression header claims " + std::to_string(blocks) + " blocks");
  const uint64_t last = blocks == 0 ? 0 : (last_size == 0 ? block_size : last_size);
  const uint64_t total = blocks == 0 ? 0 : (blocks - 1) * block_size + last;
  if (blocks > 0 && (block_size == 0 || last > block_size || total / block_size + 1 < blocks))
    throw invalid_input(f.path, what + ": its compression header is inconsistent");
  if (!fits(total)) throw wrong_size(total);
  std::vector<uint64_t> sizes(blocks);
  for (uint64_t& s : sizes) s = h.next();
  std::string out(total, '\0');
  size_t in_at = h.at, out_at = 0;
  for (uint64_t b = 0; b < blocks; ++b) {
    if (bytes.size() - in_at < sizes[b])
      throw invalid_input(f.path, what + ": its data is cut off");
    uLongf got = static_cast<uLongf>(b + 1 == blocks ? last : block_size);
    const uLongf want = got;
    const int rc = uncompress(reinterpret_cast<Bytef*>(out.data() + out_at), &got,
                              reinterpret_cast<const Bytef*>(bytes.data() + in_at),
                              static_cast<uLong>(sizes[b]));
    if (rc != Z_OK || got != want)
      throw invalid_input(f.path,
                          what + ": its zlib data is corrupt (block " + std::to_string(b) + ")");
    in_at += sizes[b];
    out_at += want;
  }
  return out;
}

size_t type_size(const std::string& type) {
  if (type == "Int8" || type == "UInt8") return 1;
  if (type == "Int16" || type == "UInt16") return 2;
  if (type == "Int32" || type == "UInt32" || type == "Float32") return 4;
  if (type == "Int64" || type == "UInt64" || type == "Float64") return 8;
  return 0;
}

template <class T>
T element(const char* p, bool swap) {
  T v;
  std::array<char, sizeof(T)> b;
  std::memcpy(b.data(), p, sizeof(T));
  if (swap) std::reverse(b.begin(), b.end());
  std::memcpy(&v, b.data(), sizeof(T));
  return v;
}

// Element `i` of `data` (of VTK type `type`) as Out.
template <class Out>
Out value_at(const std::string& type, const char* data, size_t i, bool swap) {
  const char* p = data + i * type_size(type);
  if (type == "Float32") return static_cast<Out>(element<float>(p, swap));
  if (type == "Float64") return static_cast<Out>(element<double>(p, swap));
  if (type == "Int8") return static_cast<Out>(element<int8_t>(p, swap));
  if (type == "UInt8") return static_cast<Out>(element<uint8_t>(p, swap));
  if (type == "Int16") return static_cast<Out>(element<int16_t>(p, swap));
  if (type == "UInt16") return static_cast<Out>(element<uint16_t>(p, swap));
  if (type == "Int32") return static_cast<Out>(element<int32_t>(p, swap));
  if (type == "UInt32") return static_cast<Out>(element<uint32_t>(p, swap));
  if (type == "Int64") return static_cast<Out>(element<int64_t>(p, swap));
  const uint64_t u = element<uint64_t>(p, swap);  // UInt64
  if constexpr (std::is_integral_v<Out>)
    if (u > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) return -1;  // out of range
  return static_cast<Out>(u);
}

// The bytes of an array in the appended section, from its offset to the next array's.
std::string_view appended_chunk(const VtkXmlFrame& f, const VtkXmlArray& a,
                                const std::string& what) {
  if (f.appended.data() == nullptr)
    throw invalid_input(f.path, what + " is appended, but the file has no <AppendedData>");
  const std::string text = get(a.attributes, "offset");
  int64_t offset = -1;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), offset);
  if (ec != std::errc() || end != text.data() + text.size() || offset < 0 ||
      static_cast<uint64_t>(offset) > f.appended.size())
    throw invalid_input(f.path, what + ": its offset '" + text + "' is not in the appended data");
  if (f.appended_raw) return f.appended.substr(static_cast<size_t>(offset));
  const auto next = std::upper_bound(f.appended_starts.begin(), f.appended_starts.end(), offset);
  const size_t stop =
      next == f.appended_starts.end() ? f.appended.size() : static_cast<size_t>(*next);
  return f.appended.substr(static_cast<size_t>(offset), stop - static_cast<size_t>(offset));
}

template <class Out>
std::vector<Out> decode(const VtkXmlFrame& f, const VtkXmlArray& a, size_t count,
                        const std::string& what) {
  const std::string type = get(a.attributes, "type");
  const size_t size = type_size(type);
  if (size == 0)
    throw invalid_input(f.path, what + " has type '" + type + "', which VTK does not write");
  if (std::is_integral_v<Out> && type.starts_with("Float"))
    throw invalid_input(f.path, what + " holds " + type + " values where indices are needed");
  const std::string format = get(a.attributes, "format");
  const bool any = count == kAnyCount;
  if (any) count = (size_t{1} << 31) / size;  // the bound: 2 GB of values
  std::vector<Out> out;
  if (format == "ascii") {
    // The count is the file's claim: reserve no more than its text could hold (a value and a
    // space each), or a claim of 10^13 values is a 80 TB allocation before the first is read.
    if (!any) out.reserve(std::min(count, a.text.size() / 2 + 1));
    const char* p = a.text.data();
    const char* stop = p + a.text.size();
    while (true) {
      while (p < stop && is_space(*p)) ++p;
      if (p == stop) break;
      Out v{};
      const auto [next, ec] = std::from_chars(p, stop, v);
      if (ec != std::errc() || (next < stop && !is_space(*next)))
        throw invalid_input(f.path, what + ": '" + std::string(p, std::min<size_t>(stop - p, 20)) +
                                        "' is not a number");
      if (out.size() == count)
        throw invalid_input(f.path, what + " holds more than the " + std::to_string(count) +
                                        " values the piece needs");
      out.push_back(v);
      p = next;
    }
    if (!any && out.size() != count)
      throw invalid_input(f.path, what + " holds " + std::to_string(out.size()) +
                                      " values where the piece needs " + std::to_string(count));
    return out;
  }
  if (count > (size_t{1} << 40) / size)
    throw invalid_input(f.path, what + ": the piece claims " + std::to_string(count) + " values");
  std::string decoded;
  std::string_view bytes;
  if (format == "binary") {
    decoded = base64_bytes(f.path, a.text, what);
    bytes = decoded;
  } else if (format == "appended") {
    bytes = appended_chunk(f, a, what);
    if (!f.appended_raw) {
      decoded = base64_bytes(f.path, bytes, what);
      bytes = decoded;
    }
  } else {
    throw invalid_input(f.path,
                        what + " has format '" + format + "' (expected ascii, binary or appended)");
  }
  const std::string data = data_bytes(f, bytes, count * size, any, size, what);
  const size_t n = data.size() / size;
  out.reserve(n);
  for (size_t i = 0; i < n; ++i) out.push_back(value_at<Out>(type, data.data(), i, f.big_endian));
  return out;
}

}  // namespace

VtkXmlFile scan_vtk_xml(const std::string& path, std::string_view s) {
  VtkXmlFile file;
  file.frame.path = path;
  file.frame.text = s;
  // Raw appended data may hold any byte, so only the text before it is scanned as XML.
  const size_t appended_tag = s.find("<AppendedData");
  const std::string_view head = s.substr(0, appended_tag);
  Attributes vtkfile;
  bool opened = false;
  std::string section;
  size_t pos = 0;
  while ((pos = head.find('<', pos)) != std::string_view::npos) {
    const bool comment = head.substr(pos, 4) == "<!--";
    const size_t end = comment ? head.find("-->", pos) : head.find('>', pos);
    if (end == std::string_view::npos)
      throw invalid_input(path, "truncated file (a tag is cut off)");
    std::string_view tag = head.substr(pos + 1, end - pos - 1);
    pos = end + 1;
    if (comment || tag.starts_with('?') || tag.starts_with('!')) continue;
    if (tag.starts_with('/')) {
      if (tag.substr(1) == section) section.clear();
      continue;
    }
    const bool empty_element = tag.ends_with('/');
    if (empty_element) tag.remove_suffix(1);
    const std::string name(tag.substr(0, std::min(tag.size(), tag.find_first_of(" \t\r\n"))));
    Attributes attributes = attributes_of(tag.substr(name.size()));
    if (name == "VTKFile") {
      opened = true;
      file.type = get(attributes, "type");
      vtkfile = std::move(attributes);
    } else if (!opened) {
      break;
    } else if (name == "Piece") {
      file.pieces.push_back({std::move(attributes), {}});
    } else if (name == "DataArray") {
      if (file.pieces.empty()) continue;  // FieldData of the whole file: not needed
      VtkXmlArray a{std::move(attributes), {}};
      if (!empty_element) {
        const size_t child = head.find('<', pos);
        const size_t close = head.find("</DataArray>", pos);
        if (close == std::string_view::npos)
          throw invalid_input(
              path, "truncated file (array '" + get(a.attributes, "Name") + "' is cut off)");
        a.text = head.substr(pos, std::min(child, close) - pos);
        pos = close + 12;
      }
      const std::string key = section + "/" + get(a.attributes, "Name");
      if (!file.pieces.back().arrays.emplace(key, std::move(a)).second)
        throw invalid_input(path, "array '" + key + "' appears twice in one piece");
    } else if (!empty_element) {
      section = name;
    }
  }
  if (!opened) throw invalid_input(path, "not a VTK XML file (no <VTKFile> element)");
  read_layout(path, vtkfile, file.frame);
  if (appended_tag != std::string_view::npos) {
    const size_t tag_end = s.find('>', appended_tag);
    const size_t close = s.rfind("</AppendedData>");
    if (tag_end == std::string_view::npos || close == std::string_view::npos || close < tag_end)
      throw invalid_input(path, "truncated file (the appended data is cut off)");
    const Attributes a = attributes_of(s.substr(appended_tag, tag_end - appended_tag));
    const std::string encoding = get(a, "encoding");
    if (encoding != "raw" && encoding != "base64")
      throw invalid_input(
          path, "the appended data's encoding '" + encoding + "' is neither raw nor base64");
    file.frame.appended_raw = encoding == "raw";
    const size_t underscore = s.find('_', tag_end);
    if (underscore == std::string_view::npos || underscore > close)
      throw invalid_input(path, "the appended data does not start with '_'");
    file.frame.appended = s.substr(underscore + 1, close - underscore - 1);
    for (const VtkXmlPiece& piece : file.pieces)
      for (const auto& [key, array] : piece.arrays) {
        int64_t offset = 0;
        const std::string text = get(array.attributes, "offset");
        if (std::from_chars(text.data(), text.data() + text.size(), offset).ec == std::errc())
          file.frame.appended_starts.push_back(offset);
      }
    std::sort(file.frame.appended_starts.begin(), file.frame.appended_starts.end());
  } else if (s.find("</VTKFile>") == std::string_view::npos) {
    throw invalid_input(path, "truncated file (no closing </VTKFile>)");
  }
  return file;
}

std::vector<double> vtk_doubles(const VtkXmlFrame& f, const VtkXmlArray& a, size_t count,
                                const std::string& what) {
  return decode<double>(f, a, count, what);
}

std::vector<int64_t> vtk_integers(const VtkXmlFrame& f, const VtkXmlArray& a, size_t count,
                                  const std::string& what) {
  return decode<int64_t>(f, a, count, what);
}

}  // namespace lamina::io::detail
