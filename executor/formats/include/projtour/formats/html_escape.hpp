#pragma once
// The one HTML escaper of the pages projtour writes (the summary page, the history page): text
// put in an element or in an attribute quoted with either quote.
#include <string>

namespace projtour {

// `s` with & < > " ' as the entities &amp; &lt; &gt; &quot; &#39;, everything else as it is.
std::string html_escape(const std::string& s);

}  // namespace projtour
