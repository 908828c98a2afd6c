// The executor library grows here.
namespace projtour {}
