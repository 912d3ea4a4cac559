// MathJax 3 for pymdownx.arithmatex (generic mode): typeset only the math it marks.
// MathJax itself (tex-chtml.js and its fonts, Apache-2.0) is served from this site,
// so the equations render without a network connection.
window.MathJax = {
  tex: {
    inlineMath: [["\\(", "\\)"]],
    displayMath: [["\\[", "\\]"]],
    processEscapes: true,
    processEnvironments: true,
  },
  options: {
    ignoreHtmlClass: ".*|",
    processHtmlClass: "arithmatex",
  },
};
