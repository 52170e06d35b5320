// Source URIs: "scheme:path?key=value&key=value". No percent-decoding: paths are taken verbatim
// up to the first '?', so a path containing '?' cannot be expressed (none of ours needs one).
#include <set>
#include <string>

#include "io/frame_source.h"

namespace ef {

namespace {
bool scheme_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '+' || c == '-' ||
         c == '.' || c == '_';
}
}  // namespace

Result<SourceUri> parse_source_uri(const std::string& uri) {
  const std::string quoted = "source URI '" + uri + "'";
  const std::size_t colon = uri.find(':');
  if (colon == std::string::npos)
    return error(ErrorCode::kInvalidArgument, quoted + ": no scheme (expected 'scheme:path', e.g. 'tum:DIR')");
  if (colon == 0) return error(ErrorCode::kInvalidArgument, quoted + ": empty scheme before ':'");
  SourceUri out;
  out.scheme = uri.substr(0, colon);
  for (char c : out.scheme) {
    if (!scheme_char(c))
      return error(ErrorCode::kInvalidArgument,
                   quoted + ": scheme '" + out.scheme + "' has a character that is not a letter, digit, '+', '-', '.' or '_'");
  }
  const std::size_t qmark = uri.find('?', colon + 1);
  out.path = uri.substr(colon + 1, qmark == std::string::npos ? std::string::npos : qmark - colon - 1);
  if (qmark == std::string::npos) return out;

  const std::string query = uri.substr(qmark + 1);
  if (query.empty()) return out;  // "klg:x.klg?" is the same as no options
  std::size_t pos = 0;
  while (pos <= query.size()) {
    std::size_t amp = query.find('&', pos);
    if (amp == std::string::npos) amp = query.size();
    const std::string item = query.substr(pos, amp - pos);
    if (item.empty())
      return error(ErrorCode::kInvalidArgument, quoted + ": empty option (two '&' in a row, or a trailing '&')");
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos)
      return error(ErrorCode::kInvalidArgument, quoted + ": option '" + item + "' has no '=' (expected key=value)");
    if (eq == 0) return error(ErrorCode::kInvalidArgument, quoted + ": option '" + item + "' has an empty key");
    std::string key = item.substr(0, eq);
    if (out.query.count(key))
      return error(ErrorCode::kInvalidArgument, quoted + ": option '" + key + "' given twice");
    out.query.emplace(std::move(key), item.substr(eq + 1));
    pos = amp + 1;
  }
  return out;
}

Status check_query_keys(const SourceUri& uri, std::initializer_list<const char*> allowed) {
  for (const auto& kv : uri.query) {
    bool found = false;
    for (const char* a : allowed) found = found || kv.first == a;
    if (found) continue;
    std::string list;
    for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
    return error(ErrorCode::kInvalidArgument, "unknown option '" + kv.first + "' for source scheme '" + uri.scheme +
                                                  "' (allowed: " + (list.empty() ? "none" : list) + ")");
  }
  return Status();
}

}  // namespace ef
