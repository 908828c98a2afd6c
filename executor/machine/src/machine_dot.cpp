#include <set>
#include <sstream>

#include "projtour/machine/machine.hpp"

namespace projtour {

namespace {

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// Edges from or to a composite attach to its initial leaf (dot cannot join clusters directly;
// ltail/lhead draw them as touching the cluster).
const StateSpec& entry_leaf(const StateSpec& s) {
  const StateSpec* cur = &s;
  while (cur->is_composite() && cur->child(cur->initial) != nullptr) {
    cur = cur->child(cur->initial);
  }
  return *cur;
}

class DotWriter {
 public:
  std::string write(const Machine& machine, const BehaviourCatalog* catalog) {
    out_ << "digraph machine {\n  compound=true;\n  rankdir=LR;\n"
         << "  node [shape=box, style=rounded, fontname=\"Helvetica\"];\n";
    write_state(machine.root(), 1);
    for (const StateSpec* s : machine.states()) write_edges(*s);
    if (catalog != nullptr) write_data_edges(machine, *catalog);
    out_ << "}\n";
    return out_.str();
  }

 private:
  // Dotted, from each state writing a key to each state reading it; they do not rank the graph.
  void write_data_edges(const Machine& machine, const BehaviourCatalog& catalog) {
    const auto keys_of = [&](const StateSpec& leaf) {
      const host::KindInfo* kind = catalog.find(leaf.behaviour);
      return kind != nullptr ? kind->keys : std::vector<host::KeyUse>{};
    };
    for (const StateSpec* reader : machine.leaves()) {
      for (const host::KeyUse& read : keys_of(*reader)) {
        if (read.access == host::KeyAccess::write) continue;
        for (const StateSpec* writer : machine.leaves()) {
          if (writer == reader) continue;
          for (const host::KeyUse& w : keys_of(*writer)) {
            if (w.access != host::KeyAccess::write || w.name != read.name) continue;
            out_ << "  " << quoted(writer->path) << " -> " << quoted(reader->path)
                 << " [label=" << quoted(read.name)
                 << ", style=dotted, color=steelblue, fontcolor=steelblue, constraint=false"
                 << (read.access == host::KeyAccess::read_if_present ? ", arrowhead=odot" : "")
                 << "];\n";
          }
        }
      }
    }
  }

  void indent(int depth) { out_ << std::string(static_cast<std::size_t>(depth) * 2, ' '); }

  void write_state(const StateSpec& s, int depth) {
    if (s.is_composite()) {
      indent(depth);
      out_ << "subgraph " << quoted("cluster_" + s.path) << " {\n";
      indent(depth + 1);
      out_ << "label=" << quoted(s.name + (s.for_each_target ? " (for each target)" : "")) << ";\n";
      for (const auto& c : s.children) write_state(*c, depth + 1);
      indent(depth);
      out_ << "}\n";
      return;
    }
    indent(depth);
    if (s.type == StateType::final_state) {
      out_ << quoted(s.path) << " [label=" << quoted(s.name) << ", shape=doublecircle];\n";
      return;
    }
    std::string label = s.name;
    if (s.behaviour != s.name) label += "\\n(" + s.behaviour + ")";
    if (s.retries > 0) label += "\\nretries " + std::to_string(s.retries);
    if (s.timeout_s > 0) {
      std::ostringstream t;
      t << s.timeout_s;
      label += "\\ntimeout " + t.str() + " s";
    }
    out_ << quoted(s.path) << " [label=\"" << label << "\"];\n";
  }

  std::string terminal(const std::string& word, const StateSpec& from) {
    const std::string id = from.parent->path + "/" + word;
    if (declared_.insert(id).second) {
      out_ << "  " << quoted(id) << " [label=" << quoted(word)
           << ", shape=plaintext, fontcolor=gray40];\n";
    }
    return id;
  }

  void write_edges(const StateSpec& s) {
    if (s.parent == nullptr) return;
    for (const auto& t : s.on) {
      for (std::size_t i = 0; i < t.targets.size(); ++i) {
        const std::string& target = t.targets[i];
        std::string to;
        std::string attrs =
            "label=" +
            quoted(i == 0 ? t.outcome : t.outcome + " (" + t.targets[i - 1] + " retries used up)");
        if (i > 0) attrs += ", style=dashed";
        if (is_reserved_target(target)) {
          to = terminal(target, s);
        } else {
          const StateSpec* dest = s.parent->child(target);
          if (dest == nullptr) continue;
          to = entry_leaf(*dest).path;
          if (dest->is_composite()) attrs += ", lhead=" + quoted("cluster_" + dest->path);
        }
        const std::string from = entry_leaf(s).path;
        if (i == 0 && s.is_composite()) attrs += ", ltail=" + quoted("cluster_" + s.path);
        out_ << "  " << quoted(from) << " -> " << quoted(to) << " [" << attrs << "];\n";
      }
    }
  }

  std::ostringstream out_;
  std::set<std::string> declared_;
};

}  // namespace

std::string machine_to_dot(const Machine& machine, const BehaviourCatalog* catalog) {
  return DotWriter().write(machine, catalog);
}

}  // namespace projtour
